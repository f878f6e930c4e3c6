"""Retries of a failed step (solver.max_halvings), nonsmooth and compliant with fixed steps.

The case: the paper's mechanism at dt = 2e-4 s with the Newton iteration cap lowered to 5.
Step 23 (t = 4.6 ms) then does not converge at h; taken as two steps of h/2 it does. The
checks: the run goes on unflagged and counts the retry; without retries the same step is
flagged and everything before it is bit for bit the same; and the retried step's outputs are
those of two plain steps of h/2 from the same state, computed here by the kernel apart (impulses
summed, the state at the step's end, the drive torque averaged).

The compliant case: the paper's mechanism with steel contacts (E 2.1e11 Pa) at dt = 1e-6 s
and the iteration cap lowered to 4: the smooth stages of two steps (rows 1219 and 1505) then
do not converge at h; taken as two steps of h/2 they do. The same checks, the retried step
against two plain steps of h/2 from the same state: the retry's Newton starts afresh where
the plain steps extrapolate their first iterates, so these agree to the solver's tolerance,
not to the bit.
"""

import copy
import warnings

import numpy as np
import pytest
from independent_energy import independent_energy_scale

import simcore
from simcore import kernels as nb
from simcore.model import SolverSettings
from simcore.model.audit import ENERGY_FLOOR_J
from simcore.model.driver import (
    _allocate,
    _compliant_state,
    _kernel_settings,
    _nonsmooth_outputs,
    _retry_settings,
    _start,
)
from simcore.model.mechanism import crank_slider

DT, MAX_ITER, T_END = 2e-4, 5, 0.005
FAILING_STEP = 22  # index k of the step k -> k+1 that fails at h (found by the run below)


def _config(max_halvings, **solver):
    overrides = [f"solver.dt={DT}", f"solver.max_iter={MAX_ITER}", f"solver.t_end={T_END}",
                 f"solver.max_halvings={max_halvings}", "solver.on_nonconvergence=warn"]
    overrides += [f"solver.{k}={v}" for k, v in solver.items()]
    return simcore.load_config(overrides=overrides)


def _run(max_halvings):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ds = simcore.run(_config(max_halvings))
    return ds, [str(w.message) for w in caught if issubclass(w.category, RuntimeWarning)]


@pytest.fixture(scope="module")
def runs():
    return {m: _run(m) for m in (0, 4)}


def test_a_step_failing_at_h_is_retried_and_the_run_goes_on_converged(runs):
    ds, warned = runs[4]
    assert ds["converged"].values.all(), "a retried step must not be flagged"
    assert not warned
    halvings = ds["halvings"].values
    assert ds.attrs["n_retried_steps"] == np.count_nonzero(halvings) > 0
    assert halvings[FAILING_STEP + 1] >= 1  # the step that fails at h (see the next test)
    assert ds.attrs["n_unconverged_steps"] == 0


def test_without_retries_the_same_step_is_flagged(runs):
    ds0, warned = runs[0]
    ds4, _ = runs[4]
    conv = ds0["converged"].values
    assert conv[FAILING_STEP + 1] == 0 and np.flatnonzero(conv == 0)[0] == FAILING_STEP + 1
    assert ds0.attrs["n_retried_steps"] == 0 and not ds0["halvings"].values.any()
    assert any(f"step {FAILING_STEP + 1}" in w for w in warned)
    # the steps before it need no retry: the same bits with and without retries
    for name in ("position", "velocity", "Lambda_N", "vn_free", "iterations"):
        a = ds0[name].values[:FAILING_STEP + 1]
        b = ds4[name].values[:FAILING_STEP + 1]
        assert np.array_equal(a, b), name


def test_an_unconverged_step_at_the_smallest_substep_stops_the_run():
    # a cap of 1 iteration fails at every substep size: the run stops (on_nonconvergence:
    # error) and the message says the step was retried
    cfg = _config(2, max_iter=1, on_nonconvergence="error")
    with pytest.raises(simcore.SolverError, match=r"up to 4 substeps \(solver.max_halvings = 2"):
        simcore.run(cfg)


def test_max_halvings_is_validated():
    with pytest.raises(simcore.ConfigError, match="max_halvings"):
        _config(11)
    with pytest.raises(ValueError, match="solver.max_halvings"):
        SolverSettings(1e-4, 1e-3, max_halvings=-1)


def _clone(x):
    return copy.deepcopy(x)  # (the work bundles share arrays: deepcopy keeps that)


def _outputs(n_rows, ndof, nc):
    rows = lambda *shape: np.zeros((n_rows, *shape))  # noqa: E731
    return nb.ChunkOutputs(rows(ndof), rows(ndof), rows(nc), rows(nc), rows(nc), rows(nc),
                           rows(nc), rows(nc), rows(nc), np.zeros(n_rows),
                           np.zeros((n_rows, 3), np.int64), np.ones(n_rows, np.int8),
                           np.zeros(n_rows), np.zeros(n_rows, np.int8))


def test_a_retried_step_is_the_sum_of_two_plain_half_steps():
    """The kernel's retried step against two steps of h/2 taken apart from the same state."""
    cfg = _config(1)
    model, _ = crank_slider(cfg["model"])
    settings = SolverSettings.from_config(cfg)
    start = _start(model, settings, None, None, 0.0)
    out = _allocate(model, settings, start, 0.0)
    rows = _nonsmooth_outputs(out)
    st = _kernel_settings(settings, start.drive_row, 0.0)
    retry = _retry_settings(model, settings)._replace(max_halvings=1)
    k = FAILING_STEP
    assert nb.integrate_chunk(0, k, st, start.arrays, start.state, rows, start.work, retry) < 0
    state0, work0 = _clone(start.state), _clone(start.work)
    # the step at h: retried once, converged
    assert nb.integrate_chunk(k, k + 1, st, start.arrays, start.state, rows, start.work,
                              retry) < 0
    assert out.halvings[k + 1] == 1 and out.converged[k + 1] == 1
    # the same step, apart: two plain steps of h/2 (2k and 2k+1 of a run at h/2), with the
    # iteration cap of a retried step's velocity jump (the other stages converged within
    # their own cap in the retry, so a higher one leaves them as they are)
    half = st._replace(h=st.h / 2, max_iter=nb.RETRY_VELOCITY_ITERATIONS * st.max_iter)
    no_retry = retry._replace(max_halvings=0)
    ndof, nc = state0.q.size, start.gap.size
    ref = _outputs(2 * k + 3, ndof, nc)
    ref.energy[2 * k] = out.energy[k]
    assert nb.integrate_chunk(2 * k, 2 * k + 2, half, start.arrays, state0, ref, work0,
                              no_retry) < 0
    a, b = 2 * k + 1, 2 * k + 2  # the rows of the two half steps
    lam_scale = np.abs(out.lambda_N[k + 1]).max()
    assert lam_scale > 0
    for name in ("lambda_N", "lambda_T"):
        summed = getattr(ref, name)[a] + getattr(ref, name)[b]
        np.testing.assert_allclose(getattr(out, name)[k + 1], summed, rtol=0,
                                   atol=1e-9 * lam_scale, err_msg=name)
    np.testing.assert_allclose(out.q[k + 1], ref.q[b], rtol=0, atol=1e-12)
    np.testing.assert_allclose(out.v[k + 1], ref.v[b], rtol=0,
                               atol=1e-9 * np.abs(ref.v[b]).max())
    torque = 0.5 * (ref.drive_torque[a] + ref.drive_torque[b])
    assert out.drive_torque[k + 1] == pytest.approx(torque, rel=1e-9, abs=1e-9)
    assert out.energy[k + 1] == pytest.approx(ref.energy[b], rel=1e-12)
    # the step's iterations: the larger of its two substeps', per stage
    np.testing.assert_array_equal(out.iterations[k + 1],
                                  np.maximum(ref.iterations[a], ref.iterations[b]))


def test_a_step_that_creates_energy_is_retried_by_the_audits_criterion():
    """A conservative run (e_N 1, mu 0, no cage damping, rho_inf 1) with an energy tolerance
    of 1e-5: steps gain more than that at h and are retried; the kernel's test is the audit's,
    so every step flagged for its own gain is one the kernel took to its smallest substep, and
    every step it accepted earlier passes the audit's formula, recomputed here from the stored
    energy. (The audit also flags windows of steps that gain together, which the kernel does
    not retry: the rows it flags beyond the steps' own gains.)"""
    overrides = ["solver.t_end=0.01", "solver.rho_inf=1", "model.e_N=1", "model.mu=0",
                 "model.cage_damping=0", "solver.on_nonconvergence=warn",
                 "solver.energy_tol=1e-5", "solver.max_halvings=2"]
    cfg = simcore.load_config(overrides=overrides)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = simcore.run(cfg)
    conv, halvings = ds["converged"].values, ds["halvings"].values
    assert not (ds["iterations"].values >= cfg["solver"]["max_iter"]).any()  # energy only
    assert ((halvings > 0) & (conv == 1)).any()  # retried for energy, then accepted
    energy = ds["energy"].values
    err = np.diff(energy)  # free drive: no drive work
    scale = independent_energy_scale(ds, cfg)
    own_gain = err > 1e-5 * scale + ENERGY_FLOOR_J
    assert np.all(conv[1:][own_gain] == 0) and np.all(halvings[1:][own_gain] == 2)
    accepted_early = halvings[1:] < 2
    assert np.all(err[accepted_early] <= 1e-5 * scale[accepted_early] + ENERGY_FLOOR_J)
    assert np.any(err[halvings[1:] == 2] > 1e-5 * scale[halvings[1:] == 2])


# --- compliant, fixed steps ---------------------------------------------------------------------

C_DT, C_MAX_ITER, C_T_END = 1e-6, 4, 0.002
C_FAILING_ROW = 1219  # the first row whose step fails at h (found by the runs below)


def _compliant_config(max_halvings, dt=C_DT):
    return simcore.load_config(overrides=[
        "model.contact_model=compliant", "model.youngs_modulus=2.1e11", f"solver.dt={dt}",
        f"solver.t_end={C_T_END}", f"solver.max_iter={C_MAX_ITER}",
        f"solver.max_halvings={max_halvings}", "solver.on_nonconvergence=warn"])


@pytest.fixture(scope="module")
def compliant_runs():
    runs = {}
    for m in (0, 4):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            ds = simcore.run(_compliant_config(m))
        runs[m] = ds, [str(w.message) for w in caught if issubclass(w.category, RuntimeWarning)]
    return runs


def test_a_compliant_step_failing_at_h_is_retried_and_the_run_goes_on(compliant_runs):
    ds, warned = compliant_runs[4]
    assert ds["converged"].values.all() and not warned
    halvings = ds["halvings"].values
    assert halvings[C_FAILING_ROW] >= 1
    assert ds.attrs["n_retried_steps"] == np.count_nonzero(halvings) > 0
    # the command line's summary counts them in the file's unit, output intervals
    from simcore.cli import summary_lines

    line = "output intervals with a retried step (taken again as substeps): "
    assert line + str(ds.attrs["n_retried_steps"]) in summary_lines(ds)


def test_without_retries_the_same_compliant_step_is_flagged(compliant_runs):
    ds0, warned = compliant_runs[0]
    ds4, _ = compliant_runs[4]
    conv = ds0["converged"].values
    assert np.flatnonzero(conv == 0)[0] == C_FAILING_ROW
    assert ds0.attrs["n_retried_steps"] == 0 and not ds0["halvings"].values.any()
    assert any(f"step {C_FAILING_ROW}" in w and "substeps" not in w for w in warned)
    # every step before it converges at h: the same bits with and without retries
    for name in ("position", "velocity", "F_N", "Lambda_N", "gap_N", "iterations"):
        a = ds0[name].values[:C_FAILING_ROW]
        b = ds4[name].values[:C_FAILING_ROW]
        assert np.array_equal(a, b), name


def test_a_failed_step_s_message_names_the_retries_each_model_takes():
    """The velocity jump's higher iteration cap in a retry is the nonsmooth model's: a
    compliant step (no jump) that fails at its smallest substep does not claim one."""
    def message(*overrides):
        cfg = simcore.load_config(overrides=["solver.max_iter=1", "solver.max_halvings=1",
                                             *overrides])
        with pytest.raises(simcore.SolverError) as err:
            simcore.run(cfg)
        return str(err.value)

    nonsmooth = message("solver.t_end=0.005")
    compliant = message("model.contact_model=compliant", "model.youngs_modulus=2.1e11",
                        "solver.dt=1e-6", "solver.t_end=0.002")
    for text in (nonsmooth, compliant):
        assert "taken again as up to 2 substeps (solver.max_halvings = 1)" in text, text
    assert "velocity jump allowed 4 iterations" in nonsmooth
    assert "velocity jump" not in compliant


def _compliant_outputs(out):
    return nb.CompliantOutputs(out.q, out.v, out.F_N, out.F_T, out.lambda_N, out.lambda_T,
                               out.gap_N, out.vn_pre, out.vn_post, out.energy, out.iterations,
                               out.converged, out.drive_torque, out.halvings)


def test_a_retried_compliant_step_is_two_plain_half_steps():
    """The kernel's retried step against two steps of h/2 taken apart from the same state
    (the first with its start accelerations corrected to h/2, as the retry's): the state at
    the step's end, the interval's largest force, its impulses and iteration counts."""
    cfg = _compliant_config(1)
    model, _ = crank_slider(cfg["model"])
    settings = SolverSettings.from_config(cfg)
    start = _start(model, settings, None, None, 0.0)
    out = _allocate(model, settings, start, 0.0)
    rows = _compliant_outputs(out)
    cs = _compliant_state(start)
    st = _kernel_settings(settings, start.drive_row, 0.0)
    k = C_FAILING_ROW - 1  # the step k -> k + 1 that fails at h
    args = (st, start.arrays, start.state, cs, rows, start.work)
    assert nb.integrate_compliant_chunk(0, k, 1, 1, True, *args) < 0
    state0, cs0, work0 = _clone((start.state, cs, start.work))
    assert nb.integrate_compliant_chunk(k, k + 1, 1, 1, True, *args) < 0
    assert out.halvings[k + 1] == 1 and out.converged[k + 1] == 1
    # apart: steps 2k and 2k + 1 of a run at h/2, no retries
    half = _allocate(model, SolverSettings.from_config(_compliant_config(0, C_DT / 2)), start,
                     0.0)
    assert nb.integrate_compliant_chunk(2 * k, 2 * k + 2, 1, 0, True,
                                        st._replace(h=st.h / 2), start.arrays, state0, cs0,
                                        _compliant_outputs(half), work0) < 0
    a, b = 2 * k + 1, 2 * k + 2
    np.testing.assert_allclose(out.q[k + 1], half.q[b], rtol=0, atol=1e-11)
    np.testing.assert_allclose(out.v[k + 1], half.v[b], rtol=0,
                               atol=1e-7 * np.abs(half.v[b]).max())
    force = np.maximum(half.F_N[a], half.F_N[b])
    assert force.max() > 0  # a contact carries load through the step
    np.testing.assert_allclose(out.F_N[k + 1], force, rtol=0, atol=1e-6 * force.max())
    impulse = half.lambda_N[a] + half.lambda_N[b]
    np.testing.assert_allclose(out.lambda_N[k + 1], impulse, rtol=0,
                               atol=1e-6 * np.abs(impulse).max())
    assert out.energy[k + 1] == pytest.approx(half.energy[b], rel=1e-9)
    np.testing.assert_array_equal(out.iterations[k + 1],
                                  np.maximum(half.iterations[a], half.iterations[b]))


#: A configuration of the hard corner (docs/reliability.md, section 7: constant drive, high
#: friction, large clearance, no cage damping), drawn by ``benchmarks/fuzz_corners.py --hard``
#: (seed 5, its sixth draw): three balls whose frictional impacts the velocity jump cannot
#: solve within solver.max_iter iterations at some steps of h.
HARD_CORNER = ["model.clearance=0.0014366670521756527", "model.mu=0.340650567222913",
               "model.omega0=197.48279337268184", "model.e_N=0.8062153310270436",
               "model.e_T=0.31645208740449016", "model.n_balls=3",
               "model.cage_stiffness=3945.9750428159964", "model.cage_damping=0.0",
               "model.drive=constant", "solver.t_end=0.02", "solver.dt=0.0001",
               "solver.on_nonconvergence=warn"]


def test_a_retried_step_gives_its_velocity_jump_more_iterations():
    """Without retries the hard corner's run has steps whose velocity jump stops at
    solver.max_iter; with them every step converges, and some retried steps' velocity jumps
    took more than max_iter iterations (up to RETRY_VELOCITY_ITERATIONS times it;
    docs/reliability.md, section 7)."""
    def run(max_halvings):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return simcore.run(simcore.load_config(
                overrides=[*HARD_CORNER, f"solver.max_halvings={max_halvings}"]))

    plain, retried = run(0), run(4)
    cap = int(retried.attrs["solver.max_iter"])
    velocity = nb.STAGE_VELOCITY
    failed = plain["converged"].values == 0
    assert failed.any() and (plain["iterations"].values[failed, velocity] >= cap).all()
    assert retried["converged"].values.all()
    halved = retried["halvings"].values > 0
    jumps = retried["iterations"].values[halved, velocity]
    assert jumps.max() > cap and jumps.max() <= nb.RETRY_VELOCITY_ITERATIONS * cap
    assert retried["iterations"].values[~halved, velocity].max() <= cap
