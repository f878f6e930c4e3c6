"""No silent wrong answer: hardened input, stability and memory limits, the energy audit, disk
full, a study that repairs itself, and the random-configuration fuzz (slow)."""

from __future__ import annotations

import contextlib
import errno
import math
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from independent_energy import (
    independent_energy,
    independent_energy_parts,
    independent_energy_scale,
)

import simcore
from simcore import kernels as nb
from simcore.config import ConfigError, load_config
from simcore.config.limits import OMEGA_DT_MAX, memory_estimate, spring_scales, values_per_step
from simcore.io import generalized, update_attributes
from simcore.model import SolverSettings
from simcore.model.audit import ENERGY_FLOOR_J, EnergyAudit
from simcore.model.driver import _audit_first
from simcore.model.mechanism import crank_slider

ROOT = Path(__file__).resolve().parents[1]
REPRO = ["model.clearance=0.002", "model.cage_stiffness=4e6", "model.cage_damping=0",
         "solver.dt=3e-4", "solver.t_end=0.0066"]


def cli(*args, timeout=60):
    cmd = [sys.executable, "-m", "simcore", "run", *args]
    start = time.perf_counter()
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, cwd=ROOT)
    return res, time.perf_counter() - start


def sets(items):
    return [arg for item in items for arg in ("--set", item)]


# --- input that cannot hurt -------------------------------------------------------------------

ALIAS_BOMB = "\n".join(["a: &a [x, x, x, x, x, x, x, x, x]"]
                       + [f"{chr(98 + i)}: &{chr(98 + i)} [{', '.join(['*' + chr(97 + i)] * 9)}]"
                          for i in range(8)]) + "\n"


def _bad_inputs(tmp):
    """(name, extra CLI arguments) of every input case the issue lists."""
    files = {
        "alias_bomb.yaml": ALIAS_BOMB.encode(),
        "duplicate.yaml": b"model:\n  mu: 0.1\n  mu: 0.2\n",
        "latin1.yaml": "model:\n  drive: fr\u00e9e\n".encode("latin-1"),
        "binary.yaml": bytes(range(256)) * 4,
        "nested.yaml": ("model:\n  mu: " + "[" * 50 + "]" * 50 + "\n").encode(),
        "long.yaml": ("model:\n  drive: " + "x" * 5000 + "\n").encode(),
    }
    for name, data in files.items():
        (tmp / name).write_bytes(data)
    (tmp / "a_folder.nc").mkdir()
    ro = tmp / "readonly"
    ro.mkdir()
    ro.chmod(0o555)
    # root writes into a mode-555 folder: use /proc, where nobody may create files
    ro_out = "/proc/run.nc" if os.geteuid() == 0 else str(ro / "run.nc")
    out = str(tmp / "run.nc")
    return [
        ("alias bomb", ["--config", str(tmp / "alias_bomb.yaml"), "--out", out], "alias"),
        ("duplicate key", ["--config", str(tmp / "duplicate.yaml"), "--out", out], "twice"),
        ("not UTF-8", ["--config", str(tmp / "latin1.yaml"), "--out", out], "UTF-8"),
        ("binary", ["--config", str(tmp / "binary.yaml"), "--out", out], "--config"),
        ("deep nesting", ["--config", str(tmp / "nested.yaml"), "--out", out], "nesting"),
        ("long value", ["--config", str(tmp / "long.yaml"), "--out", out], "characters"),
        ("deep --set", [*sets(["model.mu=" + "[" * 50 + "]" * 50]), "--out", out], "nesting"),
        ("1e8 steps", [*sets(["solver.t_end=1000", "solver.dt=1e-5"]), "--out", out],
         "solver.t_end"),
        ("1e7 steps", [*sets(["solver.t_end=100", "solver.dt=1e-5"]), "--out", out],
         "solver.max_memory_gb"),
        ("--out read-only", ["--out", ro_out], "--out"),
        ("--out directory", ["--out", str(tmp / "a_folder.nc")], "directory"),
        ("--out not .nc", ["--out", str(tmp / "run.txt")], ".nc"),
        ("quoted number", [*sets(['model.mu="0.2"']), "--out", out], "model.mu"),
        ("unresolved dt", [*sets(REPRO), "--out", out], "solver.dt"),
        ("unresolved dt, constant drive", [*sets(REPRO + ["model.drive=constant"]), "--out", out],
         "solver.dt"),
    ]


def test_every_bad_input_is_one_line_exit_2_no_file_fast(tmp_path):
    cases = _bad_inputs(tmp_path)
    files = sorted(tmp_path.rglob("*"))
    for name, args, word in cases:
        res, seconds = cli(*args)
        lines = res.stderr.strip().splitlines()
        assert res.returncode == 2, (name, res.returncode, res.stderr)
        assert len(lines) == 1 and lines[0].startswith("error: "), (name, res.stderr)
        assert word in lines[0], (name, lines[0])
        # no hang, no simulation before the check (the timing on an idle machine, < 2 s, is
        # measured by benchmarks/bench_bad_input.py; a loaded CI machine may take longer)
        assert seconds < 15.0, (name, seconds)
        assert sorted(tmp_path.rglob("*")) == files, name  # nothing written


def test_loader_refuses_aliases_and_duplicates_in_overrides():
    for item, word in (("model.mu=&x 0.1", "alias"), ("model.mu={a: 1, a: 2}", "twice"),
                       ("model.mu=" + "1" * 5000, "characters")):
        with pytest.raises(ConfigError, match=word) as err:
            load_config(overrides=[item])
        assert str(err.value).startswith("model.mu:") and "\n" not in str(err.value)


def test_study_refuses_a_quoted_number_in_a_sweep(tmp_path):
    cfg = tmp_path / "quoted.yaml"
    cfg.write_text('sweep:\n  mu: ["0.2", 0.1]\n')
    bomb = tmp_path / "bomb.yaml"
    bomb.write_text(ALIAS_BOMB)
    for path, words in ((cfg, ("sweep.mu.0", "'0.2'", "a number")), (bomb, ("alias",))):
        proc = subprocess.run([sys.executable, "-m", "snakemake", "--nolock", "-n",
                               "--configfile", "config/smoke.yaml", str(path)],
                              cwd=ROOT, capture_output=True, text=True, timeout=120)
        out = proc.stdout + proc.stderr
        assert proc.returncode != 0
        line = [x for x in out.splitlines() if "invalid configuration" in x]
        assert len(line) == 1 and all(w in line[0] for w in words), out


# --- stability and memory limits --------------------------------------------------------------

@pytest.mark.parametrize("n_balls", [3, 8, 13])
def test_spring_bound_is_the_highest_mode_of_the_cage_ring(n_balls):
    """Gershgorin's bound against the eigenvalues of the ring of balls and springs (tangential
    chain: m x'' = k (x_{i+1} - 2 x_i + x_{i-1})), computed here with numpy."""
    cfg = load_config(overrides=[f"model.n_balls={n_balls}"])
    model, _ = crank_slider(cfg["model"])
    k, m = cfg["model"]["cage_stiffness"], cfg["model"]["ball_mass"]
    K = 2.0 * np.eye(n_balls) - np.roll(np.eye(n_balls), 1, 0) - np.roll(np.eye(n_balls), -1, 0)
    omega_ring = math.sqrt(np.linalg.eigvalsh(k / m * K).max())
    bound = spring_scales(model).omega_max
    assert bound >= omega_ring * (1 - 1e-12)
    if n_balls % 2 == 0:  # the alternating mode exists: the bound is exact
        assert bound == pytest.approx(omega_ring, rel=1e-12)
    c = cfg["model"]["cage_damping"]
    assert spring_scales(model).zeta == pytest.approx(c / math.sqrt(k * m), rel=1e-12)


def test_paper_case_passes_and_the_reproduction_is_refused():
    model, _ = crank_slider(load_config()["model"])
    assert spring_scales(model).zeta > 1  # overdamped: no limit
    cfg = load_config(overrides=REPRO)
    model, _ = crank_slider(cfg["model"])
    scales = spring_scales(model)
    assert scales.omega_max * 3e-4 > OMEGA_DT_MAX
    with pytest.raises(ConfigError, match=r"^solver\.dt: 0\.0003 is not allowed; allowed: <= "):
        simcore.run(cfg)
    ok = load_config(overrides=REPRO + [f"solver.dt={0.9 * scales.dt_limit}"])
    from simcore.config.limits import check_run, check_run_of_config

    assert check_run(ok) == [] and check_run_of_config(ok) == []
    # the command line's model-free check gives the same limit as the built model's
    with pytest.raises(ConfigError) as from_config:
        check_run_of_config(cfg)
    with pytest.raises(ConfigError) as from_model:
        check_run(cfg, model)
    assert str(from_config.value) == str(from_model.value)


@pytest.mark.parametrize("contact_model, dt, output_dt", [("nonsmooth", 1e-4, None),
                                                          ("compliant", 1e-6, 2e-5)])
def test_memory_estimate_counts_the_arrays_of_a_run(contact_model, dt, output_dt):
    """Every per-row array the run returns (the 1-byte flags counted as 8 B), one row per
    output interval."""
    from simcore.config import output_every
    from simcore.model import Trajectory

    t_end = 0.001
    cfg = load_config(overrides=[f"model.contact_model={contact_model}", f"solver.dt={dt}",
                                 f"solver.t_end={t_end}", "model.youngs_modulus=2.1e11"]
                      + ([f"solver.output_dt={output_dt}"] if output_dt else []))
    model, _ = crank_slider(cfg["model"])
    traj = model.simulate(SolverSettings.from_config(cfg))
    arrays = [getattr(traj, name) for name in Trajectory.ROW_FIELDS]
    arrays += [traj.extras["energy_audit"].error, traj.extras["energy_audit"].tolerance]
    stored = sum(a.size * max(a.itemsize, 8) for a in arrays if a is not None)
    every, compliant = output_every(cfg), contact_model == "compliant"
    assert traj.time.size == round(t_end / dt) // every + 1
    assert memory_estimate(model, dt, t_end, every, compliant) == stored
    assert values_per_step(model, compliant=compliant) * 8 * traj.time.size == stored


def test_memory_check_counts_output_rows_not_steps():
    """A long compliant run with sparse output (1e7 steps, 1e4 rows) fits; the same run
    writing every step (1e7 rows x 9 arrays per contact) is refused, naming the key."""
    from simcore.config.limits import check_memory_of_config

    items = ["model.contact_model=compliant", "model.youngs_modulus=2.1e11",
             "solver.dt=1e-7", "solver.t_end=1.0"]
    sparse = load_config(overrides=items + ["solver.output_dt=1e-4"])
    assert check_memory_of_config(sparse) < 0.1e9
    with pytest.raises(ConfigError, match=r"^solver\.t_end: .*max_memory_gb"):
        check_memory_of_config(load_config(overrides=items))


# --- the energy audit -------------------------------------------------------------------------

class _Drive:
    """A model stand-in with a prescribed rotation at ``rate`` (for the audit only)."""

    def __init__(self, rate):
        from simcore.kernels import JOINT_ANGLE

        self.joints = [(JOINT_ANGLE, 0, -1, (0.0, rate, 0, 0, 0, 0))]


def test_audit_balances_drive_work_and_catches_a_gain():
    h, rate, tau, n = 1e-4, 50.0, 2.0, 40
    energy = 10.0 + tau * rate * h * np.arange(n + 1)  # driven at constant torque: no error
    torque = np.full(n + 1, tau)
    audit = EnergyAudit(_Drive(rate), h, n, energy_tol=5e-3)
    conv = np.ones(n + 1, np.int8)
    assert audit.check(energy, torque, conv, 0, n) == -1 and conv.all()
    assert np.abs(audit.error).max() < 1e-12
    energy[25:] += 0.06  # one step creates 0.06 J > 5e-3 * ~10 J
    audit = EnergyAudit(_Drive(rate), h, n, energy_tol=5e-3)
    assert audit.check(energy, torque, conv, 0, 20) == -1
    assert audit.check(energy, torque, conv, 20, n) == 24
    assert np.flatnonzero(conv == 0).tolist() == [25]
    assert audit.error[25] == pytest.approx(0.06)
    assert "step 25" in audit.message(24) and "solver.energy_tol" in audit.message(24)


def test_audit_scale_is_the_larger_of_E_and_the_terms_given():
    """E near 0 (the datum) with 1 J of kinetic energy: a gain of 1e-6 J is rounding against
    the terms given (5e-3 J allowed), a gain against |E| alone (1e-9 J allowed)."""
    h, n = 1e-4, 10
    energy = np.full(n + 1, 1e-12)
    energy[6:] += 1e-6
    torque = np.zeros(n + 1)
    audit = EnergyAudit(_Drive(0.0), h, n, energy_tol=5e-3)
    assert audit.check(energy, torque, np.ones(n + 1, np.int8), 0, n, np.ones(n)) == -1
    assert audit.tolerance[1:] == pytest.approx(5e-3 + ENERGY_FLOOR_J)
    audit = EnergyAudit(_Drive(0.0), h, n, energy_tol=5e-3)
    assert audit.check(energy, torque, np.ones(n + 1, np.int8), 0, n) == 5


def test_stored_energy_is_kinetic_plus_potential_plus_springs():
    cfg = load_config(overrides=["solver.t_end=0.01", "model.drive=constant"])
    ds = simcore.run(cfg)
    np.testing.assert_allclose(ds["energy"].values, independent_energy(ds, cfg),
                               rtol=1e-12, atol=1e-12)
    # the audit's error is the energy change minus the drive's work, step by step
    rate, h = cfg["model"]["omega0"], cfg["solver"]["dt"]
    expected = np.diff(ds["energy"].values) - ds["drive_torque"].values[1:] * rate * h
    np.testing.assert_allclose(ds["energy_error"].values[1:], expected, rtol=0, atol=1e-12)
    assert ds["energy_error"].attrs["units"] == "J"


@pytest.mark.parametrize("drive", ["free", "constant"])
def test_dissipative_runs_never_gain_energy(drive):
    cfg = load_config(overrides=["solver.t_end=0.03", "model.e_N=0.5", "model.mu=0.25",
                                 f"model.drive={drive}"])
    ds = simcore.run(cfg)  # on_nonconvergence = error: a gain would have stopped it
    assert int(ds["converged"][1:].min()) == 1
    scale = independent_energy_scale(ds, cfg)
    assert np.all(ds["energy_error"].values[1:] <= cfg["solver"]["energy_tol"] * scale
                  + ENERGY_FLOOR_J)
    assert ds.attrs["energy_balance_J"] < 0  # over the run, energy was dissipated


def _window_flags(error, tolerance):
    """The rows the audit's window criterion flags, restated as a plain loop: the gain since
    the lowest cumulative error of the current window above the tolerance; a flagged row
    starts the next window."""
    flags, cumulative, lowest = [], 0.0, 0.0
    for i in range(1, error.size):
        cumulative += error[i]
        lowest = min(lowest, cumulative)
        if cumulative - lowest > tolerance[i - 1]:
            flags.append(i)
            lowest = cumulative
    return flags


def test_audit_flags_steps_that_gain_together_each_within_the_tolerance():
    """10 J gaining 0.01 J a step (0.1 % each, 0.5 % allowed): each step passes, every fifth
    or sixth is flagged for what the window since the last flag gained; gains of 0.04 J, each
    lost again in the next step, are never flagged."""
    h, n = 1e-4, 40
    energy = 10.0 + 0.01 * np.arange(n + 1)
    torque = np.zeros(n + 1)
    audit = EnergyAudit(_Drive(0.0), h, n, energy_tol=5e-3)
    conv = np.ones(n + 1, np.int8)
    first = audit.check(energy, torque, conv, 0, 17)  # two chunks: the window carries over
    assert audit.check(energy, torque, conv, 17, n) >= 0 and first >= 0
    assert (audit.error[1:] < audit.tolerance[1:]).all()
    flags = np.flatnonzero(conv == 0).tolist()
    expected = _window_flags(audit.error, 5e-3 * np.maximum.accumulate(np.abs(energy))
                             + ENERGY_FLOOR_J)
    assert flags == expected and flags[0] == first + 1 == 6 and len(flags) >= 6
    message = audit.message(first)
    assert "steps 1 to 6 (t = 0 to 0.0006 s) created 0.06 J together" in message, message
    assert "each within the tolerance" in message
    steps = np.where(np.arange(n) % 2 == 0, 0.04, -0.05)  # each gain of 0.04 J lost again
    zigzag = 10.0 + np.concatenate([[0.0], np.cumsum(steps)])
    audit = EnergyAudit(_Drive(0.0), h, n, energy_tol=5e-3)
    assert audit.check(zigzag, torque, np.ones(n + 1, np.int8), 0, n) == -1


def test_a_conservative_run_that_gains_energy_is_flagged():
    """e_N = 1, mu = 0, no cage damping, rho_inf = 1: Newton's law on contacts that close in
    the same step makes the nonsmooth scheme gain energy, each step well within the tolerance;
    the audit's window flags the rows where the gain since the last flag passes it (restated
    here from the stored errors and the independent energy scale), and by default stops the
    run naming the window."""
    overrides = ["solver.t_end=0.03", "model.e_N=1", "model.mu=0", "model.cage_damping=0",
                 "solver.rho_inf=1"]
    with pytest.raises(simcore.SolverError, match=r"steps \d+ to \d+ .* created .* together"):
        simcore.run(load_config(overrides=overrides))
    cfg = load_config(overrides=overrides + ["solver.on_nonconvergence=warn"])
    with pytest.warns(RuntimeWarning, match="together"):
        ds = simcore.run(cfg)
    e = ds["energy"].values
    assert ds.attrs["energy_balance_J"] == pytest.approx(e[-1] - e[0], abs=1e-9)  # free drive
    tol = cfg["solver"]["energy_tol"]
    assert 0 < ds.attrs["energy_max_gain_relative"] < tol < \
        ds.attrs["energy_max_window_gain_relative"]
    flagged = np.flatnonzero(ds["converged"].values == 0).tolist()
    expected = _window_flags(ds["energy_error"].values,
                             tol * independent_energy_scale(ds, cfg) + ENERGY_FLOOR_J)
    assert flagged == expected and ds.attrs["n_energy_gain_steps"] == len(flagged) > 0


@pytest.mark.parametrize("every", [1, 2, 5])
def test_the_first_failure_is_judged_by_rows_whatever_output_every(every):
    """The audit places a gain only to an output row, a step that did not converge to its step:
    a failed step in the audit's row (or an earlier one) is named first, a later one second,
    for every step of every row and every output_every (an adaptive run's kernel returns a
    row, which the loop turns into the row's last step)."""
    for gain in range(4):  # the audit's row: gain + 1, steps gain*every .. (gain+1)*every - 1
        for bad in range(8 * every):  # 0-based step
            step_row = bad // every + 1
            assert _audit_first(gain, bad, every) == (gain + 1 < step_row), (gain, bad)
        for row in range(1, 8):  # adaptive: the row's last step
            assert _audit_first(gain, row * every - 1, every) == (gain + 1 < row)
        assert _audit_first(gain, -1, every)  # no failed step


def test_reproduction_with_warn_is_stopped_by_the_energy_audit(tmp_path):
    """With the dt limit only warned about and no retries, the run that went from 33.6 J to
    467 kJ stops at the first step that creates energy, naming it; with both policies at warn,
    every such step is flagged."""
    out = tmp_path / "r.nc"
    no_retry = REPRO + ["solver.on_unresolved_dt=warn", "solver.max_halvings=0"]
    res, _ = cli(*sets(no_retry), "--out", str(out))
    assert res.returncode == 3 and not out.exists(), res.stderr
    assert "energy audit: step" in res.stderr and "created" in res.stderr
    cfg = load_config(overrides=no_retry + ["solver.on_nonconvergence=warn"])
    with pytest.warns(RuntimeWarning):
        ds = simcore.run(cfg)
    flagged = ds["converged"].values[1:] == 0
    gained = ds["energy_error"].values[1:] > cfg["solver"]["energy_tol"] * 33.0
    assert gained.any() and np.all(flagged[gained])
    assert ds.attrs["n_unconverged_steps"] >= int(gained.sum())


def test_reproduction_with_retries_takes_the_gaining_steps_in_halves():
    """The same run with the default retries: the steps that create energy at h are taken
    again in halves by the audit's criterion, so no step is flagged and the energy (free drive:
    nothing puts energy in) never rises above its start by more than the audit allows."""
    cfg = load_config(overrides=REPRO + ["solver.on_unresolved_dt=warn"])
    with pytest.warns(Warning, match="running anyway"):  # the dt limit's warning
        ds = simcore.run(cfg)  # on_nonconvergence = error: a step flagged would stop it
    assert ds.attrs["n_retried_steps"] > 0 and ds.attrs["n_unconverged_steps"] == 0
    e = ds["energy"].values
    assert e.max() <= e[0] * (1 + cfg["solver"]["energy_tol"])
    assert np.all(ds["energy_error"].values[1:] <= cfg["solver"]["energy_tol"] * e[0]
                  + ENERGY_FLOOR_J)


@pytest.mark.parametrize("drive", ["free", "constant"])
def test_paper_case_has_no_gain(drive):
    cfg = load_config(overrides=["solver.t_end=0.05", f"model.drive={drive}"])
    ds = simcore.run(cfg)
    assert ds.attrs["n_energy_gain_steps"] == 0
    assert ds.attrs["energy_max_gain_relative"] < 1e-4


def test_a_mechanism_released_from_rest_is_judged_against_its_kinetic_energy():
    """The crank released from rest under gravity (free drive, omega0 0): gravity's potential
    turns into kinetic energy and E stays at its start, near 0 by the choice of datum. The
    audit's scale is then the kinetic and spring energy (recomputed here apart from the
    kernels); against max |E| alone the floor of 1e-9 J would judge the rounding of the run's
    kinetic energy, and some step would be refused."""
    cfg = load_config(overrides=["model.drive=free", "model.omega0=0", "solver.t_end=0.02"])
    ds = simcore.run(cfg)  # on_nonconvergence = error: a gain would have stopped it
    # the time loop's retries judge by the same scale: no step was taken again for a gain
    assert ds.attrs["n_retried_steps"] == 0 and int(ds["halvings"].max()) == 0
    energy = ds["energy"].values
    scale = independent_energy_scale(ds, cfg)
    # E stays near its start (0: the datum), what impacts dissipate; the kinetic energy grows
    assert scale[-1] > 100 * np.abs(energy).max()
    error = ds["energy_error"].values[1:]
    tol = cfg["solver"]["energy_tol"]
    assert np.all(error <= tol * scale + ENERGY_FLOOR_J)
    datum_bound = tol * np.maximum.accumulate(np.abs(energy))[:-1] + ENERGY_FLOOR_J
    assert np.any(error > datum_bound)  # |E| alone: a false gain
    assert 0 < ds.attrs["energy_max_gain_relative"] < 1e-4


def test_the_kernels_energy_scale_is_the_larger_of_E_and_E_without_gravity():
    """:func:`simcore.kernels.energy_scale_terms_into` against the parts recomputed from the
    stored state, on rows where either part is the larger."""
    cfg = load_config(overrides=["model.drive=free", "model.omega0=0", "solver.t_end=0.01"])
    ds = simcore.run(cfg)
    model, _ = crank_slider(cfg["model"])
    q = generalized(ds)["q"].values.reshape(ds.sizes["time"], -1)
    terms = np.empty(q.shape[0])
    energy = ds["energy"].values
    nb.energy_scale_terms_into(energy, q, model.arrays(), 0, q.shape[0], terms)
    expected = np.maximum(np.abs(energy), independent_energy_parts(ds, cfg)[0])
    np.testing.assert_allclose(terms, expected, rtol=1e-9, atol=1e-12)
    assert terms[0] == pytest.approx(abs(energy[0]))  # at rest: |E|, no kinetic energy
    assert terms[-1] > 1e3 * abs(energy[-1])  # falling: the kinetic energy


# --- disk full --------------------------------------------------------------------------------

@contextlib.contextmanager
def _full_disk(tmp_path, fake_failure):
    """(folder, make_full): a folder on a real 64 kB file system (a tmpfs, as root), or
    without mount rights an ordinary folder where ``make_full()`` (``fake_failure``) installs
    the netCDF library's "HDF error" and a file system with no free space."""
    mnt = tmp_path / "small"
    mnt.mkdir()
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(mnt)],
                             capture_output=True).returncode == 0 if os.geteuid() == 0 else False
    try:
        yield mnt, (lambda: None) if mounted else fake_failure
    finally:
        if mounted:
            # lazy: the HDF5 library may keep the handle of the failed file until exit
            subprocess.run(["umount", "-l", str(mnt)], check=True)


def _hdf_error(*args, **kwargs):
    raise RuntimeError("NetCDF: HDF error")


def _no_free_space(monkeypatch):
    monkeypatch.setattr(shutil, "disk_usage", lambda p: shutil._ntuple_diskusage(1, 1, 0))


def test_disk_full_says_so(tmp_path, monkeypatch):
    ds = xr.Dataset({"a": ("x", np.random.default_rng(0).random(200_000))})

    def fake():
        monkeypatch.setattr("simcore.io.netcdf.to_netcdf4", _hdf_error)
        _no_free_space(monkeypatch)

    with _full_disk(tmp_path, fake) as (mnt, make_full):
        make_full()
        with pytest.raises(OSError, match="No space left on device") as err:
            simcore.write_netcdf(ds, mnt / "big.nc")
        assert err.value.errno == errno.ENOSPC
        assert not list(mnt.iterdir())  # no temporary file left


def test_attributes_on_a_full_disk_say_so_and_keep_the_file(tmp_path, monkeypatch):
    """A file of 40 kB on a 64 kB disk: its copy does not fit."""
    import netCDF4

    ds = xr.Dataset({"a": ("x", np.random.default_rng(0).random(5_000))}, attrs={"k": 1})

    def fake():
        monkeypatch.setattr(netCDF4, "Dataset", _hdf_error)
        _no_free_space(monkeypatch)

    with _full_disk(tmp_path, fake) as (mnt, make_full):
        path = simcore.write_netcdf(ds, mnt / "run.nc", complevel=0)
        before = path.read_bytes()
        make_full()
        message = f"No space left on device while writing {re.escape(str(path))}"
        with pytest.raises(OSError, match=message) as err:
            update_attributes(path, {"k": 2})
        assert err.value.errno == errno.ENOSPC
        assert list(mnt.iterdir()) == [path]  # no temporary file left
        assert path.read_bytes() == before


# --- a study that repairs itself --------------------------------------------------------------

@pytest.mark.slow
def test_study_repairs_truncated_and_deleted_outputs(tmp_path):
    sys.path.insert(0, str(ROOT / "tests"))
    try:
        from test_workflow import _check_study, job_counts
    finally:
        sys.path.pop(0)
    results = tmp_path / "res"
    args = ["-j2", "--configfile", "config/smoke.yaml", "--config",
            f"study={{'results_dir': '{results}'}}"]

    def study():
        proc = subprocess.run([sys.executable, "-m", "snakemake", "--nolock", *args], cwd=ROOT,
                              capture_output=True, text=True, timeout=900)
        assert proc.returncode == 0, proc.stdout + proc.stderr
        return proc.stdout + proc.stderr

    try:
        study()
        before = {p.relative_to(results): xr.load_dataset(p) for p in results.rglob("*.nc")}
        runs = sorted((results / "runs").glob("*.nc"))
        impacts = sorted((results / "impacts").glob("*.nc"))
        with open(runs[0], "r+b") as fh:
            fh.truncate(runs[0].stat().st_size // 2)
        runs[1].unlink()
        with open(impacts[2], "r+b") as fh:
            fh.truncate(100)
        impacts[3].unlink()
        shutil.rmtree(results / "figures")
        out = study()
        assert "repair:" in out
        counts = job_counts(out)
        assert counts["summarize"] == 1 and counts["figures"] == 1
        _check_study(results)
        after = {p.relative_to(results): xr.load_dataset(p) for p in results.rglob("*.nc")}
        assert set(after) == set(before)
        for rel, ds in before.items():  # the same results again (the same machine, code)
            for name in ds.data_vars:
                if "wall_time" not in name:
                    np.testing.assert_array_equal(ds[name].values, after[rel][name].values)
        assert "Nothing to be done" in study()
    finally:
        shutil.rmtree(ROOT / "logs" / "_".join(results.relative_to(results.anchor).parts),
                      ignore_errors=True)


# --- the random-configuration fuzz ------------------------------------------------------------

@pytest.mark.slow
def test_fuzz_no_silent_gain_or_penetration():
    proc = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "fuzz_corners.py"), "150",
                           "0.05", "11"], cwd=ROOT, capture_output=True, text=True,
                          timeout=1200, env=dict(os.environ, PYTHONPATH=str(ROOT)))
    assert proc.returncode == 0, proc.stdout + proc.stderr
    print(proc.stdout)
    last = proc.stdout.strip().splitlines()[-1]
    assert last == "silent: 0 0", proc.stdout


# --- scale-out: the summary on a dask LocalCluster --------------------------------------------

def test_summary_on_a_local_dask_cluster_equals_the_synchronous_one(tmp_path):
    pytest.importorskip("distributed")
    sys.path.insert(0, str(ROOT / "tests"))
    try:
        from test_summary import _impacts, _point, _run
    finally:
        sys.path.pop(0)
    from analysis.summary import summarize

    runs, impacts = [], []
    for clearance in (1e-4, 4e-4):
        for mu in (0.0, 0.01):
            point = _point(clearance, mu)
            failed = clearance == 4e-4 and mu == 0.0
            _run(tmp_path / f"r{clearance}_{mu}.nc", point, failed=failed)
            _impacts(tmp_path / f"i{clearance}_{mu}.nc", point, failed=failed)
            runs.append(tmp_path / f"r{clearance}_{mu}.nc")
            impacts.append(tmp_path / f"i{clearance}_{mu}.nc")
    local = summarize(runs, impacts, scheduler="local", num_workers=2)
    plain = summarize(runs, impacts, scheduler="synchronous")
    for ds in (local, plain):  # the history line carries a time stamp
        ds.attrs.pop("history")
    xr.testing.assert_identical(local, plain)
    assert int(local["failed"].sum()) == 1


def test_repair_finds_unreadable_and_orphaned_files_and_a_dry_run_touches_nothing(tmp_path):
    from simcore.study.repair import looking_only, repair_outputs

    def nc(path):
        xr.Dataset({"a": ("x", np.arange(1000.0))}).to_netcdf(path)
        return path

    runs = [nc(tmp_path / f"run{i}.nc") for i in range(3)]
    tables = [nc(tmp_path / f"imp{i}.nc") for i in range(3)]
    summary = nc(tmp_path / "summary.nc")
    with open(runs[0], "r+b") as fh:
        fh.truncate(runs[0].stat().st_size // 2)
    runs[1].unlink()
    before = sorted(tmp_path.iterdir())
    dry = repair_outputs(runs, tables, summary, remove=False)
    assert sorted(tmp_path.iterdir()) == before  # a dry run only reports
    done = repair_outputs(runs, tables, summary)
    assert dry == done and len(done) == 4  # run0, imp0, imp1, summary
    assert sorted(p.name for p in tmp_path.iterdir()) == ["imp2.nc", "run2.nc"]
    assert repair_outputs(runs[2:], tables[2:], summary) == []
    assert looking_only(["snakemake", "-j2", "-n"]) and looking_only(["snakemake", "-np"])
    assert looking_only(["snakemake", "--lint"]) and looking_only(["snakemake", "--report=r.html"])
    assert not looking_only(["snakemake", "-j2", "--nolock", "--configfile", "config/smoke.yaml"])


# --- compliant contacts: the step must resolve a Hertz contact --------------------------------

def test_hertz_contact_time_matches_an_integrated_impact():
    """The limit's contact time against a direct integration of m x'' = -K x^1.5."""
    from scipy.integrate import solve_ivp

    from simcore.config import load_config
    from simcore.config.limits import hertz_contact_time

    model = load_config(overrides=["model.youngs_modulus=2.1e11"])["model"]
    E, nu = model["youngs_modulus"], model["poisson_ratio"]
    r_b, r_a = model["ball_radius"], model["inner_radius"]
    r_c = r_a + 2 * r_b + model["clearance"]
    R = r_b * r_c / (r_c - r_b)  # the outer race, the stiffer contact
    K = 4.0 / 3.0 * E / (2 * (1 - nu * nu)) * np.sqrt(R)
    m, v = model["ball_mass"], model["omega0"] * model["crank_length"]

    def rhs(_t, y):
        return [y[1], -K * max(y[0], 0.0) ** 1.5 / m]

    def released(_t, y):
        return y[0]
    released.terminal, released.direction = True, -1
    sol = solve_ivp(rhs, (0.0, 1e-3), [1e-15, v], events=released, rtol=1e-10, atol=1e-16)
    assert hertz_contact_time(model) == pytest.approx(sol.t_events[0][0], rel=0.01)


def test_compliant_step_must_resolve_the_contact():
    from simcore.config import load_config
    from simcore.config.limits import check_run_of_config, hertz_contact_time

    steel = ["model.contact_model=compliant", "model.youngs_modulus=2.1e11"]
    cfg = load_config(overrides=steel + ["solver.dt=1e-4"])
    with pytest.raises(ConfigError, match=r"^solver\.dt: .*compliant contact"):
        check_run_of_config(cfg)
    ok = load_config(overrides=steel + ["solver.dt=1e-6"])
    assert check_run_of_config(ok) == []
    assert 1e-6 <= hertz_contact_time(ok["model"]) / 5
    with pytest.warns(RuntimeWarning, match="solver.dt"):
        load_warn = load_config(overrides=steel + ["solver.dt=1e-4",
                                                   "solver.on_unresolved_dt=warn"])
        assert len(check_run_of_config(load_warn)) == 1
