"""Compliant zoom on a nonsmooth run: restart from the run's state, force histories, the CLI
verb, and the impact table's F_max_zoom."""

import warnings

import numpy as np
import pytest

import analysis
import simcore
from analysis.zoom import add_zoom_forces
from simcore.cli import main
from simcore.config import ConfigError, load_config
from simcore.io import generalized
from simcore.model import ReleaseStop, SolverSettings


@pytest.fixture(scope="module")
def run_ds():
    return simcore.run(load_config(overrides=["solver.t_end=0.004"]))


@pytest.fixture(scope="module")
def first_impact(run_ds):
    lam = run_ds["Lambda_N"].values
    k = np.unravel_index(int(np.argmax(lam)), lam.shape)
    return float(run_ds.time[k[0]]), int(run_ds.contact[k[1]])


def test_zoom_restarts_from_the_state_before_the_impact(run_ds, first_impact):
    time, contact = first_impact
    z = simcore.zoom(run_ds, time, window=1e-3, dt=1e-6)
    i = int(np.searchsorted(run_ds.time.values, time)) - 1
    assert z.attrs["zoom_start_time"] == pytest.approx(float(run_ds.time[i]))
    assert z.attrs["contact_model"] == "compliant"
    zq, rq = generalized(z), generalized(run_ds)  # q and v from position/angle, velocities
    np.testing.assert_array_equal(zq["q"].isel(time=0).values, rq["q"].isel(time=i).values)
    np.testing.assert_array_equal(zq["v"].isel(time=0).values, rq["v"].isel(time=i).values)
    F = z["F_N"].sel(contact=contact).values
    assert F.max() > 0.0 and F[0] == 0.0
    # the bearing then carries the load: its contacts stay closed, the window bounds the zoom
    assert float(z.time[-1]) == pytest.approx(float(z.time[0]) + 1e-3)
    assert int(z["converged"].min()) == 1
    # same mechanism as the run: the slider does not jump at the restart
    assert abs(float(z.slider_x[1]) - float(run_ds.slider_x[i])) < 1e-5


def test_zoom_time_outside_the_run_is_refused(run_ds):
    with pytest.raises(ConfigError, match=r"^time: 0\.5 is not allowed"):
        simcore.zoom(run_ds, 0.5)
    with pytest.raises(ConfigError, match=r"^time: 0\.0 is not allowed"):
        simcore.zoom(run_ds, 0.0)


def test_cli_zoom(run_ds, first_impact, tmp_path, capsys):
    run_file = tmp_path / "run.nc"
    simcore.write_netcdf(run_ds, run_file)
    out = tmp_path / "z.nc"
    assert main(["zoom", str(run_file), "--time", "0.5", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: --time: 0.5 is not allowed") and "\n" not in err
    assert not out.exists()
    assert main(["zoom", str(run_file), "--time", "0.001", "--set", "model.damping_law=x",
                 "--out", str(out)]) == 2
    assert "model.damping_law" in capsys.readouterr().err and not out.exists()
    time, _ = first_impact
    assert main(["zoom", str(run_file), "--time", str(time), "--window", "5e-4", "--quiet",
                 "--out", str(out)]) == 0
    import xarray as xr

    with xr.open_dataset(out) as z:
        assert float(z["F_N"].max()) > 0.0
        assert z["F_N"].attrs["units"] == "N"


def test_impact_table_gets_zoom_forces(run_ds):
    imp = analysis.extract_impacts(run_ds)
    table = add_zoom_forces(run_ds, imp, zoom_top=2)
    zoomed = np.isfinite(table["F_max_zoom"].values)
    top = np.argsort(-imp["impulse"].values, kind="stable")[:2]
    assert set(np.flatnonzero(zoomed)) == set(top)
    assert np.all(table["F_max_zoom"].values[zoomed] > 0.0)
    ct = table["contact_time_zoom"].values[zoomed]
    assert np.all(np.isnan(ct) | (ct > 0.0))
    assert table["F_max_zoom"].attrs["units"] == "N"
    assert table["contact_time_zoom"].attrs["units"] == "s"
    off = add_zoom_forces(run_ds, imp, zoom_top=0)
    assert np.all(np.isnan(off["F_max_zoom"].values))
    with pytest.raises(ValueError, match="analysis.zoom_top"):
        add_zoom_forces(run_ds, imp, zoom_top=-1)


def test_simulation_stops_once_the_contacts_have_opened_again():
    """ReleaseStop: a ball thrown at a plane (no gravity) stops the run soon after it
    leaves the plane, long before the requested end."""
    from simcore.model.mechanism import ball_on_plane

    model = ball_on_plane(radius=0.01, mass=0.0327, height=0.01 + 1e-6, e_N=1.0, gravity=0.0,
                          speed=(0.0, -1.0))
    settings = SolverSettings(1e-7, 1e-2, contact_model="compliant", chunk=100)
    traj = model.simulate(settings, release=ReleaseStop())
    assert traj.F_N.max() > 0.0 and traj.F_N[-1, 0] == 0.0
    assert traj.time[-1] < 2e-4
    assert traj.v[-1, 1] > 0.99


def test_contact_time_of_a_sampled_hertz_pulse_is_found_between_samples():
    """An undamped Hertz contact: the indentation leaves and returns to zero linearly in time,
    the force goes as its 3/2 power. Sampled at dt = T/40 (the zoom's step), the duration is
    found to a small fraction of a step, where counting samples errs by up to a step."""
    from analysis.zoom import _first_episode

    T, dt = 1.7e-4, 1.7e-4 / 40
    for shift in (0.0, 0.13, 0.5, 0.91):  # where the contact starts within a step
        t = np.arange(-5, 60) * dt
        delta = np.sin(np.pi * (t - shift * dt) / T)
        force = np.where((t - shift * dt > 0) & (t - shift * dt < T), delta, 0.0) ** 1.5
        assert _first_episode(force, dt) == pytest.approx(T, rel=2e-3)
    assert _first_episode(np.zeros(5), dt) == 0.0
    assert _first_episode(np.array([0.0, 2.0, 0.0, 0.0]), dt) == pytest.approx(dt)  # one sample
    assert np.isnan(_first_episode(np.array([0.0, 1.0, 2.0]), dt))


def test_zoom_step_follows_the_hertz_contact_time(run_ds):
    """dt = t_Hertz / N: a 100 times stiffer material shortens a Hertz contact by 100^(2/5)
    (t ~ K^(-2/5)), a faster impact by (v ratio)^(1/5); the run's own step caps it."""
    from analysis.zoom import STEPS_PER_CONTACT, zoom_step
    from simcore.config.limits import hertz_contact_time
    from simcore.study.zoom import zoom_config

    soft = zoom_config(run_ds)["model"]
    stiff = zoom_config(run_ds, overrides=["model.youngs_modulus=2.1e11"])["model"]
    assert soft["youngs_modulus"] == 2.1e9
    h_soft = zoom_step(soft, 1.0, [0.5], STEPS_PER_CONTACT)
    h_stiff = zoom_step(stiff, 1.0, [0.5], STEPS_PER_CONTACT)
    assert h_soft / h_stiff == pytest.approx(100.0 ** 0.4, rel=1e-12)
    assert h_soft == pytest.approx(hertz_contact_time(soft) / STEPS_PER_CONTACT)
    fast = 20.0 * abs(soft["omega0"]) * soft["crank_length"]  # 20 times the pin speed
    assert zoom_step(soft, 1.0, [fast], 1) == pytest.approx(
        hertz_contact_time(soft) / 20.0 ** 0.2, rel=1e-12)
    assert zoom_step(soft, 1e-7, [0.5], 1) == 1e-7


def test_impact_table_records_the_zoom_step(run_ds):
    from analysis.zoom import STEPS_PER_CONTACT
    from simcore.config.limits import hertz_contact_time

    imp = analysis.extract_impacts(run_ds)
    table = add_zoom_forces(run_ds, imp, zoom_top=1)
    zoomed = np.isfinite(table["F_max_zoom"].values)
    t_hertz = hertz_contact_time(simcore.validate_config(
        {"model": {k.split(".", 1)[1]: v for k, v in run_ds.attrs.items()
                   if k.startswith("model.")}})["model"])
    assert table["dt_zoom"].attrs["units"] == "s"
    np.testing.assert_allclose(table["dt_zoom"].values[zoomed], t_hertz / STEPS_PER_CONTACT)
    assert np.all(np.isnan(table["dt_zoom"].values[~zoomed]))
    assert table.attrs["zoom_steps_per_contact"] == STEPS_PER_CONTACT


def _ball_episode_peak(F_ball, F_contact):
    """The definition of F_max_zoom written as a plain walk over the samples (independent of
    analysis.zoom): from the impact contact's first force, walk back and forth while the ball
    carries a force; the largest force on that stretch, NaN if it is the last sample."""
    n = len(F_ball)
    # a force at the first sample alone is the run's state at the solver's tolerance
    first = next((i for i in range(n) if F_contact[i] > 0.0
                  and (i > 0 or n == 1 or F_contact[1] > 0.0)), None)
    lo, hi = 0, n - 1
    if first is not None:
        lo = first
        while lo > 0 and F_ball[lo - 1] > 0.0:
            lo -= 1
        hi = first
        while hi + 1 < n and F_ball[hi + 1] > 0.0:
            hi += 1
    best = max(range(lo, hi + 1), key=lambda i: (F_ball[i], -i))
    return np.nan if best == n - 1 else F_ball[best]


def test_episode_peak_takes_the_impact_of_the_ball_only():
    from analysis.zoom import _episode_peak, _first_episode, _struck

    contact = np.array([0.0, 0.0, 1.0, 2.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    other = np.array([0.0, 0.5, 0.0, 0.0, 3.0, 0.0, 9.0, 9.5, 0.0])  # the ball's other contact
    ball = np.maximum(contact, other)
    # the episode runs from sample 1 (the other contact closed first) to 5: peak 3.0; the
    # later, larger contact (9.5) is another episode
    assert _episode_peak(ball, contact) == 3.0 == _ball_episode_peak(ball, contact)
    rising = np.array([0.0, 1.0, 2.0, 3.0])
    assert np.isnan(_episode_peak(rising, rising))
    never = np.zeros(4)  # the impact's contact never closes: the ball's whole zoom
    assert _episode_peak(np.array([0.0, 2.0, 1.0, 0.0]), never) == 2.0
    # a touch at the first sample alone (the run's state) is not the impact
    touch = np.array([1e-14, 0.0, 0.0, 5.0, 7.0, 0.0])
    assert _episode_peak(touch, _struck(touch)) == 7.0 == _ball_episode_peak(touch, touch)
    assert _first_episode(_struck(touch), 1.0) > 1.0
    held = np.array([1.0, 2.0, 0.0])  # closed at the first two samples: kept
    np.testing.assert_array_equal(_struck(held), held)


def test_zoom_stops_when_the_balls_are_free_and_reports_the_full_window_numbers(run_ds,
                                                                                monkeypatch):
    """The early stop on the impacts' balls: each number of the table equals the one read
    from a zoom over the whole window (until_released=False), by the independent walk above,
    and the stopped zooms are shorter."""
    from analysis.zoom import _first_episode

    imp = analysis.extract_impacts(run_ds)
    calls = []
    zoom_trajectory = simcore.study.zoom.zoom_trajectory

    def recording(run, time, **kw):
        out = zoom_trajectory(run, time, **kw)
        calls.append((time, kw, out[0].time.size))
        return out

    monkeypatch.setattr(simcore.study.zoom, "zoom_trajectory", recording)
    table = add_zoom_forces(run_ds, imp, zoom_top=3)
    monkeypatch.undo()
    stopped = 0
    for time, kw, n_rows in calls:
        with warnings.catch_warnings():  # (the zooms of the table flag what they find)
            warnings.simplefilter("ignore", RuntimeWarning)
            full = simcore.zoom(run_ds, time, window=kw["window"], dt=kw["dt"],
                                until_released=False, overrides=kw["overrides"])
        stopped += n_rows < full.sizes["time"]
        F = full["F_N"].values
        for row in np.flatnonzero(np.isclose(table["time"].values, time, rtol=0, atol=0)):
            if not np.isfinite(table["dt_zoom"].values[row]):
                continue
            contact = int(table["contact"].values[row])
            ball = full["ball"].values == int(table["ball"].values[row])
            expected = _ball_episode_peak(F[:, ball].max(axis=1), F[:, contact])
            got = float(table["F_max_zoom"].values[row])
            assert got == expected or (np.isnan(got) and np.isnan(expected))
            Fc = F[:, contact].copy()
            if Fc[0] > 0.0 and Fc[1] == 0.0:
                Fc[0] = 0.0
            t_full = _first_episode(Fc, float(full.attrs["solver.output_dt"]))
            got = float(table["contact_time_zoom"].values[row])
            assert got == t_full or (np.isnan(got) and np.isnan(t_full))
    assert stopped >= 1


def test_watch_contacts_waits_for_the_onset_of_its_group():
    """A group's episode starts at its onset contact: a ball thrown at a plane with its only
    contact watched stops after the rebound; the same run watching for an onset that never
    comes (an empty onset) runs to its end. A wrong shape is refused naming the key."""
    from simcore.model.mechanism import ball_on_plane

    model = ball_on_plane(radius=0.01, mass=0.0327, height=0.01 + 1e-6, e_N=1.0, gravity=0.0,
                          speed=(0.0, -1.0))
    settings = SolverSettings(1e-7, 5e-4, contact_model="compliant", chunk=100)
    traj = model.simulate(settings, release=ReleaseStop([True], [True]))
    assert traj.F_N.max() > 0.0 and traj.F_N[-1, 0] == 0.0 and traj.time[-1] < 2e-4
    whole = model.simulate(settings, release=ReleaseStop([True], [False]))
    assert whole.time[-1] == pytest.approx(5e-4)
    np.testing.assert_array_equal(whole.F_N[:len(traj.time)], traj.F_N)
    with pytest.raises(ValueError, match="^watch_contacts"):
        model.simulate(settings, release=ReleaseStop([True, False]))
