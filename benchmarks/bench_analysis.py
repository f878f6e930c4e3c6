"""Benchmark of the analysis: filter throughput and the cost of force extraction per impact.

    python benchmarks/bench_analysis.py [--runs 16] [--steps 3000] [--repeat 7]

Prints the filter's throughput in samples per second over a stack of runs (runs x 16 contacts x
(steps + 1) samples, all at once along the last axis), and the median cost of one Flores peak
force: a simple impact (cached per e_N after the first) and an impact on persistent contact (one
integration each, compiled Dormand-Prince with an LSODA fallback for stiff cases), and the
whole extract_impacts of one synthetic run (in-plane contacts and a grooved race), the
vectorised Hertz stresses, and, with --run FILE.nc, extract_impacts of a real run file.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from analysis import contact_stress, extract_impacts, hertz_stiffness, peak_force, split_impulses
from analysis.forces import _scaled_impact
from analysis.synthetic import make_run_dataset


def _median_time(fn, repeat):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", type=int, default=16)
    ap.add_argument("--steps", type=int, default=3000)
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--run", default=None, help="a run file (python -m simcore run --out ...)")
    args = ap.parse_args(argv)

    rng = np.random.default_rng(0)
    shape = (args.runs, 16, args.steps + 1)
    lam = rng.random(shape) * (rng.random(shape) > 0.5) * 1e-3
    split_impulses(lam[:1, :1, :10], 1e-4)  # compile / load the cached kernel
    t = _median_time(lambda: split_impulses(lam, 1e-4), args.repeat)
    n = lam.size
    print(f"filter: {n:,} samples ({args.runs} runs x 16 contacts x {args.steps + 1} steps) "
          f"in {t * 1e3:.1f} ms -> {n / t / 1e6:.1f} M samples/s (median of {args.repeat})")

    K = hertz_stiffness(0.0055, 0.033745, 2.1e9, 0.3, 2.1e9, 0.3)
    n_imp = 50
    imp = rng.uniform(1e-4, 1e-2, n_imp)
    v = rng.uniform(0.01, 1.0, n_imp)
    fs = rng.uniform(1.0, 100.0, n_imp)

    def simple_uncached():
        _scaled_impact.cache_clear()
        peak_force(imp[0], v[0], 0.9, K)

    def simple_cached():
        for i in range(n_imp):
            peak_force(imp[i], v[i], 0.9, K)

    def persistent():
        _scaled_impact.cache_clear()
        for i in range(n_imp):
            peak_force(imp[i], v[i], 0.9, K, F_static=fs[i])

    t1 = _median_time(simple_uncached, args.repeat)
    t2 = _median_time(simple_cached, args.repeat) / n_imp
    t3 = _median_time(persistent, args.repeat) / n_imp
    print(f"peak force, simple impact, first of its e_N (one integration): "
          f"{t1 * 1e3:.2f} ms")
    print(f"peak force, simple impact, cached scaled solution: {t2 * 1e6:.1f} us per impact")
    print(f"peak force, impact on persistent contact: {t3 * 1e3:.2f} ms per impact")

    run = make_run_dataset(n_steps=args.steps)
    extract_impacts(run)

    def whole():
        _scaled_impact.cache_clear()
        return extract_impacts(run)

    t4 = _median_time(whole, args.repeat)
    ni = whole().sizes["impact"]
    print(f"extract_impacts on a synthetic run ({args.steps} steps, {ni} impacts): "
          f"{t4 * 1e3:.1f} ms -> {t4 / max(ni, 1) * 1e3:.2f} ms per impact")

    t5 = _median_time(lambda: extract_impacts(run, groove_conformity=0.52), args.repeat)
    print(f"extract_impacts, elliptical contacts (groove_conformity 0.52): {t5 * 1e3:.1f} ms")

    forces = rng.uniform(1.0, 1e4, 100_000)
    t6 = _median_time(lambda: contact_stress(forces, 0.0055, 0.045145, "outer", 2.1e11, 0.3,
                                             conformity=0.52), args.repeat)
    print(f"Hamrock-Brewe stresses of 100,000 forces: {t6 * 1e3:.1f} ms")

    if args.run:
        import xarray as xr

        with xr.open_dataset(args.run) as ds:
            real = ds.load()
        extract_impacts(real)
        t7 = _median_time(lambda: extract_impacts(real), args.repeat)
        ni = extract_impacts(real).sizes["impact"]
        print(f"extract_impacts on {args.run} ({real.sizes['time'] - 1} steps, {ni} impacts): "
              f"{t7 * 1e3:.1f} ms")


if __name__ == "__main__":
    main()
