"""Rating lives read from a compliant run (analysis.run_life), on a run built here from closed
forms: the inner ring turns under a load fixed in space, the outer ring stands still, the balls
roll (cage at the pure-rolling speed) and carry the static load distribution of their ring."""

import numpy as np
import pytest
import xarray as xr

from analysis import life
from analysis.load_distribution import ball_loads, ball_stiffness
from analysis.run_life import compliant_life
from analysis.synthetic import PAPER_MODEL

F_R = 2000.0     # radial load [N]
OMEGA = 50.0     # crank speed [rad/s]
DT = 2.0e-4      # output interval [s]
CLEARANCE = 1e-5
LOAD_ANGLE = -0.5 * np.pi  # the load pushes the inner ring towards -y


def _rolling_ring_run(revolutions=3.0):
    """The run file's variables of a ring under a constant load (see the module docstring)."""
    r_b, r_a = PAPER_MODEL["model.ball_radius"], PAPER_MODEL["model.inner_radius"]
    Z, L1 = 8, PAPER_MODEL["model.crank_length"]
    gamma = r_b / (r_a + r_b)  # D_w / D_pw
    cage = OMEGA * (1.0 - gamma) / 2.0
    t = np.arange(int(round(revolutions * 2 * np.pi / OMEGA / DT)) + 1) * DT
    theta = OMEGA * t
    pin = L1 * np.stack([np.cos(theta), np.sin(theta)], axis=-1)
    phi = cage * t[:, None] + 2 * np.pi * np.arange(Z)[None, :] / Z  # ball angles in space
    _, _, K_s = ball_stiffness(r_b, r_a, CLEARANCE, PAPER_MODEL["model.youngs_modulus"],
                               PAPER_MODEL["model.poisson_ratio"])
    Q = np.array([ball_loads(F_R, row, CLEARANCE, K_s, LOAD_ANGLE).Q for row in phi])
    pitch = r_a + r_b + CLEARANCE / 2
    balls = pin[:, None, :] + pitch * np.stack([np.cos(phi), np.sin(phi)], axis=-1)
    n = t.size
    position = np.zeros((n, 3 + Z, 2))
    position[:, 3:, :] = balls
    angle = np.zeros((n, 3 + Z))
    angle[:, 0] = theta
    bodies = ["crank", "rod", "slider"] + [f"ball{j}" for j in range(Z)]
    impulse = np.concatenate([Q, Q], axis=1) * DT  # inner contacts, then outer
    attrs = dict(PAPER_MODEL, **{"model.clearance": CLEARANCE, "model.n_balls": Z,
                                 "output_interval_s": DT, "contact_model": "compliant",
                                 "model.contact_model": "compliant"})
    ds = xr.Dataset(
        {"Lambda_N": (("time", "contact"), impulse), "F_N": (("time", "contact"), impulse / DT),
         "crank_angle": ("time", theta), "journal_x": ("time", np.zeros(n)),
         "journal_y": ("time", np.zeros(n)), "position": (("time", "body", "axis"), position),
         "angle": (("time", "body"), angle)},
        coords={"time": t, "contact": np.arange(2 * Z),
                "ball": ("contact", np.tile(np.arange(Z), 2)),
                "race": ("contact", ["inner"] * Z + ["outer"] * Z), "body": bodies,
                "axis": ["x", "y"]},
        attrs=attrs)
    return ds, Q, phi, K_s


@pytest.fixture(scope="module")
def ring():
    return _rolling_ring_run()


def test_l10_is_the_cube_of_c_over_the_cubic_mean_of_the_transmitted_load(ring):
    ds, Q, phi, _ = ring
    settings = {"life_conformity": [0.52, 0.53]}
    out = compliant_life(ds, -np.inf, settings)
    # the load the ring transmits, |sum_j Q_j n_j|, its revolution-weighted cubic mean
    F = np.hypot((Q * np.cos(phi)).sum(axis=1), (Q * np.sin(phi)).sum(axis=1))
    w = np.full(F.size, DT)
    w[[0, -1]] = DT / 2
    P = (np.sum(w * F**3) / np.sum(w)) ** (1 / 3)
    assert P == pytest.approx(F_R, rel=0.02)  # the distribution balances F_r along the load
    D_w = 2 * PAPER_MODEL["model.ball_radius"]
    D_pw = D_w + 2 * PAPER_MODEL["model.inner_radius"]
    C = life.bearing_capacity_lp(life.raceway_capacity(D_w, D_pw, 0.52, 8, "inner"),
                                 life.raceway_capacity(D_w, D_pw, 0.53, 8, "outer"), 8)
    assert out["load_rating"] == pytest.approx(C, rel=1e-12)
    assert out["equivalent_load"] == pytest.approx(P, rel=1e-9)
    assert out["L10"] == pytest.approx((C / P) ** 3, rel=1e-9)
    assert out["L10h"] == pytest.approx(out["L10"] * 1e6 / (OMEGA / (2 * np.pi)) / 3600,
                                        rel=1e-6)
    # a load rating given in the settings is used as given
    given = compliant_life(ds, -np.inf, dict(settings, life_load_rating=30e3))
    assert given["L10"] == pytest.approx((30e3 / P) ** 3, rel=1e-9)
    # ISO 76: P0 the largest transmitted load, s0 = C0 / P0 with C0 of the modelled ring, or
    # the catalogue's where the run names a bearing (the file's positions are float32)
    C0 = life.static_load_rating(D_w, D_pw, 8, 0.52, 0.53)
    assert out["static_equivalent_load"] == pytest.approx(F.max(), rel=1e-6)
    assert out["static_load_rating"] == pytest.approx(C0, rel=1e-12)
    assert out["static_safety_factor"] == pytest.approx(C0 / F.max(), rel=1e-6)
    named = compliant_life(ds.assign_attrs({"model.bearing": "6012"}), -np.inf, settings)
    assert named["static_load_rating"] == 23.2e3


def test_l10r_lies_between_the_static_lives_of_the_ring_positions(ring):
    """The inner ring turns relative to the load (cubic mean), the outer ring stands still
    (10/3-mean over its circumference): the reference life of the rolling ring lies between
    those of a static distribution with a ball under the load and with two balls astride."""
    ds, _, _, K_s = ring
    out = compliant_life(ds, -np.inf, {"life_conformity": [0.52, 0.53]})
    D_w = 2 * PAPER_MODEL["model.ball_radius"]
    D_pw = D_w + 2 * PAPER_MODEL["model.inner_radius"]
    Q_ci = life.raceway_capacity(D_w, D_pw, 0.52, 8, "inner")
    Q_ce = life.raceway_capacity(D_w, D_pw, 0.53, 8, "outer")
    static = []
    for phase in (0.0, np.pi / 8):  # a ball under the load, two astride
        angles = LOAD_ANGLE + phase + 2 * np.pi * np.arange(8) / 8
        dist = ball_loads(F_R, angles, CLEARANCE, K_s, LOAD_ANGLE)
        static.append(life.reference_life_static(dist.Q, Q_ci, Q_ce, rotating="inner").L10r)
    assert min(static) * 0.99 <= out["L10r"] <= max(static) * 1.01
    assert out["L10rh"] == pytest.approx(out["L10r"] * 1e6 / (OMEGA / (2 * np.pi)) / 3600,
                                         rel=1e-6)


def test_the_window_starts_after_the_settle_time(ring):
    ds, _, _, _ = ring
    whole = compliant_life(ds, -np.inf, {})
    later = compliant_life(ds, float(ds.time[len(ds.time) // 3]), {})
    # a steady load: the same lives over two thirds of the window (to the sampling)
    assert later["L10"] == pytest.approx(whole["L10"], rel=0.02)
    assert np.isnan(compliant_life(ds, float(ds.time[-1]), {})["L10"])


def test_conformities_come_from_the_settings_then_the_catalogue_then_the_default(ring,
                                                                                 monkeypatch):
    """analysis.life_conformity where given; else the named catalogue entry's f_i, f_e (here
    changed to tell them from the default); else 0.52, 0.53."""
    from analysis.run_life import DEFAULT_CONFORMITY, conformities, ring_geometry
    from simcore.model.bearing import catalogue

    ds = ring[0]
    named = ds.assign_attrs({"model.bearing": "6012"})
    monkeypatch.setitem(catalogue()["6012"], "f_i", 0.515)
    assert conformities(named, {"life_conformity": [0.55, 0.56]}) == (0.55, 0.56)
    assert conformities(named, {"life_conformity": None}) == (0.515, 0.53)
    assert conformities(ds, {}) == DEFAULT_CONFORMITY == (0.52, 0.53)
    assert ring_geometry(named, {})["conformity"] == (0.515, 0.53)
    # an entry without conformities (the paper's ring) falls back to the default
    paper = ds.assign_attrs({"model.bearing": "6012-paper"})
    assert conformities(paper, {}) == DEFAULT_CONFORMITY
