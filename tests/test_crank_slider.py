"""The paper's crank-slider with its ball bearing: invariants and the ideal mechanism."""

import numpy as np
import pytest

import simcore
from simcore import kernels as nb
from simcore.io import generalized
from simcore.model.mechanism import crank_slider


def _run(**overrides):
    """A run with the generalized coordinates q and v (time, body, dof) added."""
    items = [f"{k.replace('__', '.')}={v}" for k, v in overrides.items()]
    return generalized(simcore.run(simcore.load_config(overrides=items)))


@pytest.fixture(scope="module")
def paper_short():
    return _run(solver__t_end=0.05)


def _joint_residuals(ds, cfg_model):
    model, _ = crank_slider(cfg_model)
    arr = model.arrays()
    m = nb.joint_row_count(arr.jt_type)
    n = arr.mdiag.size
    worst = 0.0
    for i in range(ds.sizes["time"]):
        q = ds["q"].values[i].ravel()
        g, G, gam, dgdt = np.zeros(m), np.zeros((m, n)), np.zeros(m), np.zeros(m)
        nb.bilateral(q, np.zeros(n), float(ds.time[i]), arr, g, G, gam, dgdt)
        worst = max(worst, np.abs(g).max())
    return worst


def test_initial_state_matches_ideal_kinematics(paper_short):
    ds = paper_short
    L1, L2, w0 = 0.11, 0.225, 50.0
    v0 = ds["v"].isel(time=0)
    assert float(v0.sel(body="crank", dof="phi")) == pytest.approx(w0)
    assert float(v0.sel(body="rod", dof="phi")) == pytest.approx(-w0 * L1 / L2)
    assert float(v0.sel(body="slider", dof="x")) == 0.0
    # no slip at either race at t = 0, as the element measures it
    model, layout = crank_slider(simcore.load_config()["model"])
    arr = model.arrays()
    q0, vel0 = model.initial_state()
    nc = arr.ct_type.size
    gap, vn, vt = np.zeros(nc), np.zeros(nc), np.zeros(nc)
    nb.contact_velocities(q0, vel0, arr, gap, vn, vt)
    race = slice(0, layout.n_race_contacts)
    np.testing.assert_allclose(vt[race], 0.0, atol=1e-12)
    np.testing.assert_allclose(gap[race], 0.0002, rtol=1e-9)  # centred: half the clearance
    # the guard contacts: neighbours a chord apart, the rings' lands a land gap apart
    rB, rA, g = 0.0055, 0.033745, 4e-4
    chord = 2 * (rA + rB + g / 2) * np.sin(np.pi / 8)
    assert layout.guards == tuple(f"ball{k}-ball{(k + 1) % 8}" for k in range(8)) + ("rings",)
    np.testing.assert_allclose(gap[16:24], chord - 2 * rB, rtol=1e-12)
    land = g + 2 * rB * (1 - 2 * 0.2)  # two shoulders of 0.2 ball diameters
    assert gap[24] == pytest.approx(land, rel=1e-12) == layout.land_gap
    assert float(ds["journal_x"][0]) == pytest.approx(0.0, abs=1e-15)
    assert float(ds["journal_y"][0]) == pytest.approx(0.0, abs=1e-15)


def test_ball0_shift_moves_ball_0_along_the_pitch_circle():
    """model.ball0_shift = s: ball 0 at angle s / R_p on the pitch circle, still centred in its
    clearance and without slip, its guard gaps to its neighbours the chords of the new angles;
    every other body where it was."""
    s, n = 1e-4, 8
    rB, rA, g = 0.0055, 0.033745, 4e-4
    pitch = rA + rB + g / 2
    states = []
    for shift in (0.0, s):
        model, layout = crank_slider(simcore.validate_config(
            {"model": {"ball0_shift": shift}})["model"])
        arr = model.arrays()
        q0, vel0 = model.initial_state()
        nc = arr.ct_type.size
        gap, vn, vt = np.zeros(nc), np.zeros(nc), np.zeros(nc)
        nb.contact_velocities(q0, vel0, arr, gap, vn, vt)
        states.append((q0.reshape(-1, 3), gap, vt))
    (q_base, gap_base, _), (q, gap, vt) = states
    ball0 = layout.balls[0]
    centre = np.array([0.11, 0.0])  # the pin, where the bearing is centred
    x, y = q[ball0, :2] - centre
    assert np.hypot(x, y) == pytest.approx(pitch, rel=1e-12)
    assert np.arctan2(y, x) == pytest.approx(s / pitch, rel=1e-9)
    others = [b for b in range(q.shape[0]) if b != ball0]
    np.testing.assert_array_equal(q[others], q_base[others])
    race = slice(0, layout.n_race_contacts)
    np.testing.assert_allclose(gap[race], g / 2, rtol=1e-9)
    np.testing.assert_allclose(vt[race], 0.0, atol=1e-12)
    # the guards after the race contacts are ball k against ball k + 1: ball 0 now s / R_p
    # nearer ball 1, as far further from ball n - 1
    step, g0 = 2 * np.pi / n, layout.n_race_contacts
    assert gap[g0] == pytest.approx(2 * pitch * np.sin((step - s / pitch) / 2) - 2 * rB,
                                    rel=1e-12)
    assert gap[g0 + n - 1] == pytest.approx(2 * pitch * np.sin((step + s / pitch) / 2) - 2 * rB,
                                            rel=1e-12)
    np.testing.assert_array_equal(gap[g0 + 1:g0 + n - 1], gap_base[g0 + 1:g0 + n - 1])


def test_no_penetration_and_every_step_converged(paper_short):
    ds = paper_short
    assert int(ds["converged"].min()) == 1
    # a 40,000th of the clearance
    assert float(ds["gap_N"].min()) >= -1e-8
    # the impulses are non-negative and only on closed contacts
    assert float(ds["Lambda_N"].min()) >= 0.0
    assert float(ds["Lambda_N"].isel(time=0).max()) == 0.0


def test_bilateral_joints_hold(paper_short):
    # Newton converges quadratically on the joints: far below the position tolerance tol*h
    assert _joint_residuals(paper_short, simcore.load_config()["model"]) <= 1e-12


def test_small_clearance_follows_the_ideal_slider_crank():
    clearance = 1e-6
    ds = _run(model__clearance=clearance, solver__t_end=0.15)
    assert int(ds["converged"].min()) == 1
    L1, L2 = 0.11, 0.225
    th = ds["crank_angle"].values
    ideal = L1 * np.cos(th) + np.sqrt(L2**2 - L1**2 * np.sin(th) ** 2)
    err = np.abs(ds["slider_x"].values - ideal)
    # the big end may sit off the pin by the clearance (slightly more between two balls)
    assert err.max() <= 3 * clearance, err.max()
    assert float(ds["gap_N"].min()) >= -1e-8


def test_free_drive_energy_never_rises(paper_short):
    e = paper_short["energy"].values
    assert paper_short.attrs["model.drive"] == "free"
    assert e.max() <= e[0] * (1 + 1e-3)
    assert e[-1] < e[0]  # dampers, restitution < 1 and friction dissipate


def test_runs_are_deterministic():
    a = _run(solver__t_end=0.01)
    b = _run(solver__t_end=0.01)
    for name in ("q", "v", "Lambda_N", "Lambda_T", "nu_N", "gap_N", "iterations"):
        np.testing.assert_array_equal(a[name].values, b[name].values)


def test_constant_drive_holds_the_crank_speed():
    ds = _run(model__drive="constant", solver__t_end=0.02)
    w = ds["v"].sel(body="crank", dof="phi").values
    np.testing.assert_allclose(w, 50.0, atol=1e-9)
    np.testing.assert_allclose(ds["crank_angle"].values, 50.0 * ds.time.values, atol=1e-9)
    assert np.abs(ds["drive_torque"].values).max() > 0.0


def test_dataset_contract(paper_short):
    ds = paper_short
    n = 8
    assert ds.sizes["contact"] == 2 * n and ds.sizes["stage"] == 3 and ds.sizes["dof"] == 3
    assert list(ds["race"].values[:n]) == ["inner"] * n
    assert list(ds["race"].values[n:]) == ["outer"] * n
    for name in ("clearance", "mu", "omega0", "e_N"):  # length-1 dimensions: runs combine
        assert ds[name].dims == (name,) and ds[name].size == 1 and name in ds.coords
    for name in ("Lambda_N", "Lambda_T", "nu_N", "gap_N", "vn_pre", "vn_post", "vn_free",
                 "position", "angle", "velocity", "angular_velocity", "crank_angle", "slider_x",
                 "slider_v", "energy", "iterations", "converged"):
        assert "units" in ds[name].attrs and "long_name" in ds[name].attrs, name
    for key in ("Conventions", "title", "source", "history", "wall_time_s", "compile_time_s",
                "model.clearance", "solver.dt"):
        assert key in ds.attrs


@pytest.mark.slow
def test_paper_case_full_length():
    ds = _run()
    assert int(ds["converged"].min()) == 1
    assert float(ds["gap_N"].min()) >= -1e-8
    e = ds["energy"].values
    assert e.max() <= e[0] * (1 + 1e-3)
    # every step restores the joints (at least one Newton iteration of the position
    # correction): what is left is one Newton step's quadratic remainder, not a drift that
    # accumulates up to the tolerance tol * h = 1e-9 m
    solver = simcore.load_config()["solver"]
    assert _joint_residuals(ds, simcore.load_config()["model"]) <= (
        1e-2 * solver["tol"] * solver["dt"])


@pytest.mark.parametrize("clearance, mu, omega0, e_N", [
    (1e-6, 0.3, 200.0, 0.0),     # many balls pinched at once: redundant contacts
    (2e-5, 0.1, 200.0, 1.0),
    (4e-4, 0.3, 200.0, 0.5),
    (4e-4, 0.0, 100.0, 1.0),
    (1e-3, 0.1, 200.0, 0.5),
])
def test_sweep_corners_converge_without_penetration(clearance, mu, omega0, e_N):
    """Corners of a wide study grid: every step converges, nothing penetrates, and the total
    energy never rises (cage dampers dissipate even with e_N = 1 and mu = 0)."""
    ds = _run(model__clearance=clearance, model__mu=mu, model__omega0=omega0, model__e_N=e_N)
    assert int(ds["converged"].min()) == 1
    assert float(ds["gap_N"].min()) >= -1e-8
    e = ds["energy"].values
    assert e.max() <= e[0] * (1 + 1e-3)


@pytest.mark.parametrize("contact_model", ["nonsmooth", "compliant"])
def test_a_run_restarted_at_t0_keeps_the_prescribed_crank_rotation(contact_model):
    """A constant-drive run restarted from its own state at t0 holds the crank at ω0 t (the
    drive's closed form) from t0 on, with every step converged (a step that took its time from
    0 instead of t0 would pull the crank back by ω0 t0 and fail)."""
    from simcore.model import SolverSettings

    items = ["model.drive=constant", "solver.t_end=0.01", f"model.contact_model={contact_model}"]
    if contact_model == "compliant":
        items += ["solver.dt=1e-6", "model.youngs_modulus=2.1e11"]
    cfg = simcore.validate_config(simcore.load_config(overrides=items))
    model, _ = crank_slider(cfg["model"])
    whole = model.simulate(SolverSettings.from_config(cfg))
    k = whole.time.size // 2
    t0 = float(whole.time[k])
    rest = model.simulate(SolverSettings.from_config(cfg, t_end=cfg["solver"]["t_end"] - t0),
                          q0=whole.q[k], v0=whole.v[k], t0=t0)
    crank = 2  # (body 0: crank, dofs x, y, phi)
    assert rest.time[0] == pytest.approx(t0, rel=1e-12)
    np.testing.assert_allclose(rest.q[:, crank], 50.0 * rest.time, rtol=1e-12)
    assert rest.converged.all()
