"""What each start-up patch saves (``simcore/startup/patches.py``), measured A/B.

Runs ``benchmarks/first_run.py`` (a new process's first run of the paper case with a warm Numba
cache; ``api``: to the dataset, ``cli``: to the written file) with every patch, with each patch
left out in turn (``BEARINGSIM_STARTUP_PATCHES`` = the others) and with none, alternating the
configurations within each round so that a shared machine's load falls on all of them alike.
Prints, per configuration, the medians of the process's CPU time (user + system, which waiting
for a core does not inflate) and of its wall time, and the median over the rounds of the
difference to the run with every patch, round by round.

``--cold`` measures the cold compile instead (``bench_core.py``'s: a new process's first
one-step run with an empty Numba cache, the compile helper's CPU included), for the patches
that act on it.

Usage: python benchmarks/bench_patches.py [--rounds 6] [--cold]
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

from bench_core import ONE_STEP, _child_env, run_child  # noqa: E402

from simcore.startup.patches import PATCHES, SWITCH  # noqa: E402

#: the patches that act on a cold compile (the others change nothing there)
COLD_PATCHES = ("numba_internal_kernels", "numba_link_only", "parallel_compile")


def configurations(names) -> dict:
    """Name: value of the switch, for every patch, each one left out, and none."""
    out = {"all": "1"}
    out.update({f"without {name}": ",".join(p for p in PATCHES if p != name) for name in names})
    out["none"] = "0"
    return out


def first_run(switch: str, path: str) -> dict:
    env = _child_env(FIRST_RUN_T0="{t0}", **{SWITCH: switch})
    row = run_child([sys.executable, os.path.join(HERE, "first_run.py"), path], env)
    return {"cpu": row["process_cpu"], "wall": row["process_wall"]}


def cold_compile(switch: str) -> dict:
    with tempfile.TemporaryDirectory() as cache:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        start = time.perf_counter()
        subprocess.run([sys.executable, "-c", ONE_STEP], capture_output=True, check=True,
                       env=_child_env(NUMBA_CACHE_DIR=cache, **{SWITCH: switch}))
        wall = time.perf_counter() - start
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    return {"cpu": cpu, "wall": wall}


def report(rows: list[dict]) -> None:
    """Medians per configuration and measure, and the median paired difference to "all"."""
    keys = sorted({(r["config"], r["what"]) for r in rows}, key=lambda k: (k[1], k[0] != "all"))
    for config, what in keys:
        mine = [r for r in rows if r["config"] == config and r["what"] == what]
        ref = {r["round"]: r for r in rows if r["config"] == "all" and r["what"] == what}
        parts = []
        for measure in ("cpu", "wall"):
            med = statistics.median(r[measure] for r in mine)
            diff = statistics.median(r[measure] - ref[r["round"]][measure] for r in mine)
            parts.append(f"{measure} {med:6.3f} s ({diff:+.3f})")
        print(f"  {what:4s} {config:28s} " + "  ".join(parts) + f"  [{len(mine)} runs]")


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--rounds", type=int, default=6)
    p.add_argument("--cold", action="store_true", help="the cold compile instead")
    args = p.parse_args()
    configs = configurations(COLD_PATCHES if args.cold else PATCHES)
    if not args.cold:  # fill the caches first
        for path in ("api", "cli"):
            first_run("1", path)
    rows = []
    for r in range(args.rounds):
        for config, switch in configs.items():
            for what in (("cold",) if args.cold else ("api", "cli")):
                row = cold_compile(switch) if args.cold else first_run(switch, what)
                rows.append({"round": r, "config": config, "what": what, **row})
    print(f"start-up patches, A/B alternated, {args.rounds} rounds; medians, and in brackets the "
          "median difference to every patch on, round by round:")
    report(rows)


if __name__ == "__main__":
    main()
