"""The impulse filter (docs/forces.md): invariants, the paper's Fig. 3 case, thresholds."""

import numpy as np
import pytest
import xarray as xr
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from analysis import split_dataset, split_impulses, zero_threshold
from analysis.synthetic import make_run_dataset

# series with many exact zeros, isolated spikes and plateaus, as the solver produces
_values = st.one_of(st.just(0.0), st.floats(0.0, 1.0), st.floats(0.0, 1e-6),
                    st.floats(0.0, 1e3, allow_subnormal=True))
nonneg_series = st.lists(_values, min_size=0, max_size=60).map(np.array)
any_series = arrays(np.float64, st.integers(0, 40),
                    elements=st.floats(-1e6, 1e6, allow_nan=False, allow_subnormal=True))


def reference_split(lam, thr):
    """Straight transcription of the paper's three functions, one sample at a time."""
    n = len(lam)
    fi = np.zeros(n)
    for k in range(1, n - 1):
        if lam[k] > thr and lam[k - 1] <= thr and lam[k + 1] <= thr:
            fi[k] = lam[k]
    aux = lam - fi
    s = aux.copy()
    for k in range(1, n - 1):
        if fi[k] == 0 and aux[k] > aux[k - 1] and aux[k] > aux[k + 1]:
            s[k] = 0.5 * (aux[k - 1] + aux[k + 1])
    return fi, s, aux - s


@settings(max_examples=300, deadline=None)
@given(nonneg_series, st.sampled_from([0.0, 1e-4, 1e-2, 0.3]))
def test_invariants_nonnegative(lam, zero_tol):
    fi, s, fisuv = split_impulses(lam, zero_tol, floor=0.0)
    thr = zero_threshold(lam, zero_tol, floor=0.0)
    assert fi.shape == s.shape == fisuv.shape == lam.shape
    # exact sum, bit for bit
    np.testing.assert_array_equal(fi + s + fisuv, lam)
    # non-negative parts for non-negative input
    assert (fi >= 0).all() and (s >= 0).all() and (fisuv >= 0).all()
    n = lam.size
    # Λ_FI non-zero only at isolated samples
    for k in np.flatnonzero(fi):
        assert 0 < k < n - 1
        assert lam[k] > thr and lam[k - 1] <= thr and lam[k + 1] <= thr
        assert fi[k] == lam[k]
    # Λ_FIsuv non-zero only at upward single-sample peaks of Λ_AUX
    aux = lam - fi
    for k in np.flatnonzero(fisuv):
        assert 0 < k < n - 1
        assert aux[k] > aux[k - 1] and aux[k] > aux[k + 1]
    # agrees with the sample-by-sample transcription of the paper
    rfi, rs, rfisuv = reference_split(lam, thr)
    np.testing.assert_array_equal(fi, rfi)
    # Λ_S is re-derived so that the sum is exact: equal to the mean within a rounding unit of Λ
    ulp = 4 * np.finfo(float).eps * (lam.max() if lam.size else 0.0)
    np.testing.assert_allclose(s, rs, rtol=0, atol=ulp)
    np.testing.assert_allclose(fisuv, rfisuv, rtol=0, atol=ulp)


@settings(max_examples=300, deadline=None)
@given(any_series)
def test_sum_is_exact_for_any_finite_series(lam):
    fi, s, fisuv = split_impulses(lam, 1e-3)
    np.testing.assert_array_equal(fi + s + fisuv, lam)


@pytest.mark.parametrize("lam", [[], [0.7], [0.0, 2.0], [1.0, 0.0]])
def test_short_series(lam):
    lam = np.array(lam, dtype=float)
    fi, s, fisuv = split_impulses(lam, 1e-4)
    np.testing.assert_array_equal(fi, 0.0 * lam)
    np.testing.assert_array_equal(fisuv, 0.0 * lam)
    np.testing.assert_array_equal(s, lam)


def test_end_samples_go_to_smooth_part():
    # an apparent isolated impact at the last step and an upward "peak" at the first
    lam = np.array([5.0, 0.0, 0.0, 0.0, 3.0])
    fi, s, fisuv = split_impulses(lam, 1e-4)
    np.testing.assert_array_equal(fi, 0.0)
    np.testing.assert_array_equal(fisuv, 0.0)
    np.testing.assert_array_equal(s, lam)


def test_paper_fig3():
    """An isolated impact at t_A and an impact on persistent contact at t_B (paper, Fig. 3)."""
    h = 1e-4
    n = 60
    lam = np.zeros(n)
    k_a, k_b = 10, 40
    lam[k_a] = 2e-3                                      # simple impact: zero on both sides
    k = np.arange(25, 55)
    lam[k] = 3e-4 + 1e-6 * np.minimum(k - 25, 54 - k)  # persistent contact, Λ ≈ F h (a hump)
    lam[k_b] += 1.5e-3                                   # impact on top of it
    fi, s, fisuv = split_impulses(lam, 1e-4)
    expected_fi = np.zeros(n)
    expected_fi[k_a] = 2e-3
    np.testing.assert_array_equal(fi, expected_fi)
    # the smooth part bridges the peak by the mean of its neighbours
    smooth = np.zeros(n)
    smooth[k] = 3e-4 + 1e-6 * np.minimum(k - 25, 54 - k)
    smooth[k_b] = 0.5 * (smooth[k_b - 1] + smooth[k_b + 1])
    np.testing.assert_allclose(s, smooth, rtol=0, atol=1e-18)
    assert np.flatnonzero(fisuv > 1e-12).tolist() == [k_b]
    np.testing.assert_allclose(fisuv[k_b], 1.5e-3 + 0.5e-6, rtol=1e-12)
    # static force of the contact at t_B
    np.testing.assert_allclose(s[k_b] / h, (3e-4 + 13.5e-6) / h, rtol=1e-12)


def test_rising_train_end_is_a_peak():
    """The paper's rule reads the last sample of a rising train before separation as an upward
    peak (it exceeds both neighbours): documented behaviour, not an impact we invent."""
    lam = np.array([0.0, 1.0, 2.0, 3.0, 0.0, 0.0])
    fi, s, fisuv = split_impulses(lam, 1e-4)
    np.testing.assert_array_equal(np.flatnonzero(fisuv), [3])
    assert s[3] == pytest.approx(1.0)


def test_one_pass_leaves_secondary_peaks():
    # smoothing the big peak lifts its value to the mean of neighbours; a neighbour that was a
    # plateau beside it stays: the rule is applied once, as in the paper
    lam = np.array([0.0, 1.0, 1.0, 3.0, 1.0, 2.0, 1.0, 1.0, 0.0])
    fi, s, fisuv = split_impulses(lam, 1e-4)
    np.testing.assert_array_equal(fi, 0.0)
    np.testing.assert_array_equal(np.flatnonzero(fisuv), [3, 5])
    np.testing.assert_allclose(s[[3, 5]], [1.0, 1.0])


def test_threshold_relative_and_floor():
    lam = np.array([0.0, 1e-9, 0.0, 0.5, 0.0, 2.0])
    assert zero_threshold(lam, 1e-4, 1e-12) == pytest.approx(2e-4)
    assert zero_threshold(np.zeros(3), 1e-4, 1e-12) == 1e-12
    assert zero_threshold(None, 1e-3, 1e-12, scale=1.0) == pytest.approx(1e-3)
    fi, _, _ = split_impulses(lam, 1e-4)
    # 1e-9 is below 1e-4 x 2 N s: numerical noise, not an impact
    assert np.flatnonzero(fi).tolist() == [3]
    fi, _, _ = split_impulses(lam, 0.0, floor=0.0)
    assert np.flatnonzero(fi).tolist() == [1, 3]


def test_ripples_only_count_above_threshold():
    """A persistent-contact train with tiny ripples: every ripple is a peak of Λ_AUX, but only
    the real impact exceeds the relative threshold (counts need the threshold)."""
    rng = np.random.default_rng(1)
    lam = np.zeros(400)
    lam[50:350] = 1e-2 + 1e-9 * rng.standard_normal(300)
    lam[200] += 5e-3
    fi, s, fisuv = split_impulses(lam, 1e-4)
    thr = zero_threshold(lam, 1e-4)
    assert (fisuv > 0).sum() > 50                 # ripples give tiny Λ_FIsuv
    assert np.flatnonzero(fisuv > thr).tolist() == [200]
    assert (fisuv > 1e-10).sum() > 50             # an absolute tiny threshold counts them all


def test_nd_matches_rows_with_common_scale():
    rng = np.random.default_rng(2)
    lam = rng.random((3, 4, 50)) * (rng.random((3, 4, 50)) > 0.6)
    fi, s, fisuv = split_impulses(lam, 1e-2)
    scale = lam.max()
    for i in range(3):
        for j in range(4):
            r = split_impulses(lam[i, j], 1e-2, scale=scale)
            np.testing.assert_array_equal(fi[i, j], r[0])
            np.testing.assert_array_equal(s[i, j], r[1])
            np.testing.assert_array_equal(fisuv[i, j], r[2])


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_bad_values_raise(bad):
    with pytest.raises(ValueError, match="lam"):
        split_impulses(np.array([0.0, bad, 0.0]), 1e-4)


@pytest.mark.parametrize("kw,name", [({"zero_tol": -1.0}, "zero_tol"), ({"zero_tol": 1.0},
                                     "zero_tol"), ({"floor": np.nan}, "floor"),
                                     ({"scale": -2.0}, "scale")])
def test_bad_settings_raise(kw, name):
    args = {"zero_tol": 1e-4, **kw}
    with pytest.raises(ValueError, match=name):
        split_impulses(np.zeros(5), **args)


def test_scalar_input_raises():
    with pytest.raises(ValueError, match="lam"):
        split_impulses(1.0, 1e-4)


def test_split_dataset_keeps_coords_units_threshold():
    run = make_run_dataset(n_steps=400)
    out = split_dataset(run, zero_tol=1e-4, zero_floor=1e-12)
    assert isinstance(out, xr.Dataset)
    for name in ("Lambda_FI", "Lambda_S", "Lambda_FIsuv"):
        assert out[name].dims == ("time", "contact")
        assert out[name].attrs["units"] == "N s"
        assert "long_name" in out[name].attrs
    for c in ("clearance", "mu", "omega0", "e_N", "ball", "race"):
        assert c in out.coords
    lam = run["Lambda_N"].values
    assert out.attrs["zero_threshold"] == pytest.approx(1e-4 * lam.max())
    total = out["Lambda_FI"] + out["Lambda_S"] + out["Lambda_FIsuv"]
    np.testing.assert_array_equal(total.values, lam)
    assert out.attrs["n_persistent"] == 2
