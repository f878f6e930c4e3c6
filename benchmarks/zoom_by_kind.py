"""The paper's method against the compliant zoom by impact kind, in steady operation.

One nonsmooth run (steel, constant drive, the reference point of the study unless overridden,
one start-up and ``--revolutions`` steady revolutions); the ``--top`` largest Flores forces of
each impact kind (simple, persistent, pinch, multi) of the steady window are zoomed
(:func:`analysis.zoom.add_zoom_forces`) and printed with the ratio F_max / F_max_zoom, the
effective mass, the approach speed and the contact time in steps, then the range of the ratio
per kind. Where the ratio leaves 1 +- analysis.method_tol the impact gets the flag
``method_disagrees``. An impact whose ball is loaded in the state a zoom would start from is not
zoomed (``zoom_loaded_start``; :func:`analysis.zoom.loaded_at_start`) and printed as such.

    python benchmarks/zoom_by_kind.py [--revolutions 1] [--top 4] [--set model.clearance=2e-5 ...]
"""

from __future__ import annotations

import argparse

import numpy as np

import analysis
import simcore
from analysis.impacts import FLAG, KIND
from analysis.summary import SteadyWindow
from analysis.zoom import add_zoom_forces

KIND_NAME = {v: k for k, v in KIND.items()}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--revolutions", type=float, default=1.0,
                   help="steady crank revolutions after the start-up (1 revolution)")
    p.add_argument("--top", type=int, default=4, help="largest impacts of each kind zoomed")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="further settings (model.clearance=2e-5, ...)")
    args = p.parse_args(argv)
    cfg = simcore.load_config(overrides=["model.drive=constant", "model.youngs_modulus=2.1e11",
                                         *args.set])
    t_end = (1.0 + args.revolutions) * 2 * np.pi / abs(cfg["model"]["omega0"])
    cfg["solver"]["t_end"] = float(np.ceil(t_end / cfg["solver"]["dt"]) * cfg["solver"]["dt"])
    run = simcore.run(cfg)
    imp = analysis.extract_impacts(run)
    window = SteadyWindow.of_run(run, 1.0)
    tol = cfg["analysis"]["method_tol"]
    print(f"{imp.sizes['impact']} impacts in {cfg['solver']['t_end']:g} s, steady after "
          f"{window.settle_time:.4f} s; method_tol = {tol:g}")
    print("| kind | time [s] | contact | F_max [N] | F_max_zoom [N] | ratio | m_eff [kg] | "
          "v_pre [m/s] | contact time [steps] | method_disagrees | loaded at start |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    ratios = {}
    force = imp["F_max"].values
    for code, name in KIND_NAME.items():
        rows = np.flatnonzero((imp["kind"].values == code) & np.isfinite(force)
                              & (imp["time"].values > window.settle_time))
        rows = np.sort(rows[np.argsort(-force[rows], kind="stable")][: args.top])
        if not rows.size:
            continue
        table = add_zoom_forces(run, imp.isel(impact=rows), zoom_top=rows.size, method_tol=tol,
                                adaptive=False)
        for i in range(rows.size):
            f, z = float(table["F_max"][i]), float(table["F_max_zoom"][i])
            ratio = f / z if np.isfinite(z) and z > 0 else np.nan
            if np.isfinite(ratio):
                ratios.setdefault(name, []).append(ratio)
            bad = bool(int(table["flags"][i]) & FLAG["method_disagrees"])
            loaded = bool(int(table["zoom_loaded_start"][i]))
            print(f"| {name} | {float(table['time'][i]):.4f} | {int(table['contact'][i])} | "
                  f"{f:,.0f} | {z:,.0f} | {ratio:.2f} | {float(table['m_eff'][i]):.3g} | "
                  f"{float(table['v_pre'][i]):.3f} | "
                  f"{float(table['contact_time_steps'][i]):.2f} | {'yes' if bad else 'no'} | "
                  f"{'yes (not zoomed)' if loaded else 'no'} |")
    print("F_max / F_max_zoom by kind:")
    for name, r in ratios.items():
        print(f"  {name}: {len(r)} impacts, {min(r):.2f} to {max(r):.2f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
