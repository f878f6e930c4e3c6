"""Cost of the retries of failed nonsmooth steps on the paper's case, where none is needed.

    PYTHONPATH=. python benchmarks/bench_halving.py [ROUNDS] [T_END] [--against DIR]
    (default 5 2.0)

Each round runs the paper's case (default configuration, ``solver.t_end = T_END``) in a fresh
process with ``solver.max_halvings`` 4 and 0, one after the other (with ``--against DIR``, a
third process runs the same case from the checkout DIR, e.g. another branch's, with its own
defaults). A process runs the case once to load the kernels, then five times, and reports the
median CPU time of ``simcore.run`` (process time: on a shared machine the wall time mostly
measures the wait for a core). Printed: the medians over the rounds and the per-round ratios
with their median, so that the alternation cancels the machine's drifts.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np

CHILD = """
import json, sys, time
import numpy as np
import simcore
cfg = simcore.load_config(overrides=sys.argv[1:])
simcore.run(cfg)
cpu = []
for _ in range(5):
    t = time.process_time()
    simcore.run(cfg)
    cpu.append(time.process_time() - t)
print(json.dumps(float(np.median(cpu))))
"""


def one(overrides, path):
    env = dict(os.environ, PYTHONPATH=path)
    res = subprocess.run([sys.executable, "-c", CHILD, *overrides], env=env, check=True,
                         capture_output=True, text=True)
    return json.loads(res.stdout.strip().splitlines()[-1])


def main(rounds=5, t_end=2.0, against=None):
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    variants = {"max_halvings=4": ([f"solver.t_end={t_end}", "solver.max_halvings=4"], here),
                "max_halvings=0": ([f"solver.t_end={t_end}", "solver.max_halvings=0"], here)}
    if against:
        variants["against"] = ([f"solver.t_end={t_end}"], os.path.abspath(against))
    cpu = {name: [] for name in variants}
    for _ in range(rounds):
        for name, (overrides, path) in variants.items():
            cpu[name].append(one(overrides, path))
    print(f"paper's case, t_end = {t_end} s, {rounds} alternated rounds; CPU s per run "
          "(median of 5 in each process)")
    for name, values in cpu.items():
        print(f"{name:16s} median {np.median(values):.4f}  rounds {np.round(values, 4)}")
    base = np.array(cpu["max_halvings=4"])
    for name in [n for n in cpu if n != "max_halvings=4"]:
        ratio = base / np.array(cpu[name])
        print(f"max_halvings=4 / {name}: median {np.median(ratio):.3f}  rounds "
              f"{np.round(ratio, 3)}")


if __name__ == "__main__":
    args = sys.argv[1:]
    other = None
    if "--against" in args:
        i = args.index("--against")
        other = args[i + 1]
        del args[i:i + 2]
    main(int(args[0]) if args else 5, float(args[1]) if len(args) > 1 else 2.0, other)
