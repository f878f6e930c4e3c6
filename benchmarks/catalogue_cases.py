"""The paper's case with catalogue bearings: what changes with the bearing and its clearance
class (docs/model.md, "A bearing from its data").

    python benchmarks/catalogue_cases.py [BEARING ...]      (default: 6012-paper 6012 6205)

For each bearing, both drives, the model's clearance (0.4 mm) and the C3 class: the balls, the
clearance, unconverged steps, the largest Newton iterations, the largest impulse, the largest
journal offset over the clearance, the three largest Flores peak forces on the outer race (the
analysis' defaults), the simple impacts and the samples where a guard contact was loaded.
"""

from __future__ import annotations

import sys

import numpy as np


def main(names) -> None:
    import analysis
    import simcore
    from analysis.impacts import top_forces

    for name in names:
        for drive in ("free", "constant"):
            for clearance_class in (None, "C3"):
                items = [f"model.bearing={name}", f"model.drive={drive}"]
                if clearance_class:
                    items.append(f"model.clearance_class={clearance_class}")
                cfg = simcore.load_config(overrides=items)
                ds = simcore.run(cfg)
                imp = analysis.extract_impacts(ds)
                top = np.sort(top_forces(imp, n=3, race="outer")["F_max"].values)[::-1]
                offset = np.hypot(ds["journal_x"].values, ds["journal_y"].values)
                m = cfg["model"]
                print(f"{name:10s} {drive:8s} {clearance_class or '-':3s} Z = {m['n_balls']:2d}, "
                      f"D_w = {2e3 * m['ball_radius']:.3f} mm, g = {m['clearance'] * 1e6:5.1f} um: "
                      f"unconverged {int((ds['converged'].values == 0).sum())}, iterations max "
                      f"{ds['iterations'].values.max(axis=0).tolist()}, largest Lambda_N "
                      f"{ds['Lambda_N'].values.max():.3g} N s, offset/g "
                      f"{offset.max() / m['clearance']:.3f}, "
                      f"outer top-3 F_max {np.round(top / 1e3, 2).tolist()} kN, simple impacts "
                      f"{imp.attrs['n_simple']}, guard samples "
                      f"{ds.attrs['guard_ball_ball_closed_samples']} / "
                      f"{ds.attrs['guard_rings_closed_samples']}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:] or ["6012-paper", "6012", "6205"])
