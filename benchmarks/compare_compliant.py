"""The compliant fixed step of this tree against another revision's, on the same cases and dt.

Runs each case twice in separate processes, once with this tree's ``simcore`` and once with a
reference revision's (``--ref-rev``, default ``main``, checked out in a temporary detached
``git worktree``, or an existing checkout given by ``--ref-path``), and compares the largest
normal force per contact in windows of ``--window`` seconds:

- ``paper``: the paper's case with steel (E = 2.1e11 Pa), free start-up, dt = 1e-6 s, output
  every 10 steps, 0.05 s (the case of ``bench_compliant.py``);
- ``steady``: the default study's model point with steel at clearance 2e-5 m, omega0 = 100
  rad/s (constant drive), dt = 1e-6 s, 0.02 s from the initial state;
- ``zoom``: the study zoom of ``bench_compliant.py`` (a steady run at clearance 1e-4 m,
  omega0 = 50 rad/s, E = 2.1e9 Pa, zoomed with compliant contacts on its largest impact,
  2,000 steps of 3.128 us).

Both trajectories are chaotic: in the paper's case a change of the last bit anywhere grows to
a change of tens of per cents of a contact's peak force within 25 ms (docs/compliant.md gives
the table). So that the comparison says what a difference means, each case is also run by the
reference with its initial ball position moved by 1e-15 m (``perturbed``): window by window, a
change of the code that stays at round-off level differs from the
reference by about as much as that perturbation does.

Usage: python benchmarks/compare_compliant.py [--ref-rev main | --ref-path DIR]
       [--cases paper steady zoom] [--window 0.005]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]

# runs inside a subprocess whose sys.path starts with the tree under test
CHILD = r"""
import sys
import numpy as np
import numba
numba.set_num_threads(1)
from simcore.config import load_config
from simcore.model import SolverSettings
from simcore.model.mechanism import crank_slider

case, perturb, out = sys.argv[1], float(sys.argv[2]), sys.argv[3]
if case in ("paper", "steady"):
    if case == "paper":
        cfg = load_config(overrides=["model.youngs_modulus=2.1e11"])
        t_end, every = 0.05, 10
    else:
        cfg = load_config("config/config.yaml", overrides=[
            "model.youngs_modulus=2.1e11", "model.clearance=2e-5", "model.omega0=100.0"])
        t_end, every = 0.02, 10
    model, layout = crank_slider(cfg["model"])
    q0, v0 = model.initial_state()
    q0[3 * layout.balls[0]] += perturb
    traj = model.simulate(SolverSettings(1e-6, t_end, contact_model="compliant",
                                         output_every=every), q0=q0, v0=v0)
    time, F = traj.time, traj.F_N
else:
    sys.path.append(sys.argv[4])  # this tree's benchmarks/, after the tree under test
    from _common import steady_run_largest_impact
    run, t_imp = steady_run_largest_impact()
    from simcore.study.zoom import zoom_trajectory
    traj = zoom_trajectory(run, t_imp, window=2000 * 3.128e-6, dt=3.128e-6,
                           until_released=False)[0]
    time, F = traj.time, traj.F_N
np.savez(out, time=time, F_N=F)
"""


def run_case(tree: Path, case: str, perturb: float, out: Path) -> dict:
    env = dict(os.environ, PYTHONPATH=str(tree))
    subprocess.run([sys.executable, "-c", CHILD, case, repr(perturb), str(out),
                    str(ROOT / "benchmarks")], cwd=tree, env=env, check=True)
    d = np.load(out)
    return {"time": d["time"], "F_N": d["F_N"]}


def window_peaks(res: dict, window: float) -> np.ndarray:
    """Largest F_N per contact in each window (rows: windows)."""
    t = res["time"] - res["time"][0]
    idx = np.minimum((t[1:] / window * (1 - 1e-12)).astype(int), int(t[-1] / window - 1e-9))
    peaks = np.zeros((idx.max() + 1, res["F_N"].shape[1]))
    np.maximum.at(peaks, idx, res["F_N"][1:])
    return peaks


def compare(a: dict, b: dict, window: float) -> list[float]:
    """Per window: the largest |peak difference| over contacts, relative to the window's
    largest peak."""
    pa, pb = window_peaks(a, window), window_peaks(b, window)
    scale = np.maximum(pa.max(axis=1), 1e-300)
    return list(np.abs(pa - pb).max(axis=1) / scale)


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--ref-rev", default="main")
    p.add_argument("--ref-path", default=None)
    p.add_argument("--cases", nargs="+", default=["paper", "steady", "zoom"])
    p.add_argument("--window", type=float, default=0.005)
    p.add_argument("--json", default=None, help="write the table to this file")
    args = p.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        ref = Path(args.ref_path) if args.ref_path else tmp / "ref"
        if not args.ref_path:
            subprocess.run(["git", "worktree", "add", "--detach", str(ref), args.ref_rev],
                           cwd=ROOT, check=True, capture_output=True)
        try:
            table = {}
            for case in args.cases:
                new = run_case(ROOT, case, 0.0, tmp / f"{case}-new.npz")
                old = run_case(ref, case, 0.0, tmp / f"{case}-ref.npz")
                identical = bool(np.array_equal(new["F_N"], old["F_N"]))
                row = {"identical": identical, "new_vs_ref": compare(new, old, args.window)}
                if case != "zoom":
                    pert = run_case(ref, case, 1e-15, tmp / f"{case}-pert.npz")
                    row["perturbed_vs_ref"] = compare(pert, old, args.window)
                table[case] = row
                print(f"{case}: bit-identical F_N: {identical}")
                print("  window [ms]      " + " ".join(
                    f"{args.window * 1e3 * (i + 1):>8.0f}" for i in range(len(row["new_vs_ref"]))))
                for key in ("new_vs_ref", "perturbed_vs_ref"):
                    if key in row:
                        print(f"  {key:<16} " + " ".join(f"{x:8.1e}" for x in row[key]))
            if args.json:
                Path(args.json).write_text(json.dumps(table, indent=1))
        finally:
            if not args.ref_path:
                subprocess.run(["git", "worktree", "remove", "--force", str(ref)], cwd=ROOT,
                               check=False, capture_output=True)


if __name__ == "__main__":
    main()
