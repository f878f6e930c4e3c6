"""What the guard contacts cost: runs with and without them (``model.guard_contacts``),
alternated in one process, medians of the integration's wall time and of the process's CPU
time (docs/model.md, "Guard contacts").

    python benchmarks/bench_guards.py [PAIRS] [--set KEY=VALUE ...]     (default 8 pairs, the
                                                                        paper's case)
"""

from __future__ import annotations

import sys
import time

import numpy as np


def main(pairs: int, overrides: list[str]) -> None:
    import simcore
    from simcore.runner import warm_up

    warm_up(simcore.load_config(overrides=overrides))
    wall = {True: [], False: []}
    cpu = {True: [], False: []}
    for i in range(pairs):
        for guards in ((True, False) if i % 2 == 0 else (False, True)):
            cfg = simcore.load_config(overrides=[*overrides,
                                                 f"model.guard_contacts={str(guards).lower()}"])
            start = time.process_time()
            ds = simcore.run(cfg)
            cpu[guards].append(time.process_time() - start)
            wall[guards].append(ds.attrs["wall_time_s"])
    for guards in (True, False):
        print(f"guard contacts {'on ' if guards else 'off'}: integration wall time median "
              f"{np.median(wall[guards]):.4f} s, run CPU time median "
              f"{np.median(cpu[guards]):.4f} s")
    print(f"on / off: wall {np.median(wall[True]) / np.median(wall[False]):.3f}, "
          f"CPU {np.median(cpu[True]) / np.median(cpu[False]):.3f} ({pairs} pairs)")


if __name__ == "__main__":
    args = sys.argv[1:]
    n = int(args.pop(0)) if args and args[0].isdigit() else 8
    items = [args[i + 1] for i in range(len(args) - 1) if args[i] == "--set"]
    main(n, items)
