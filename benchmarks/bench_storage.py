"""Bytes of a run file (README, "The run file"): the paper's case with the default
``study.keep`` and with every variable, per variable, and the same for a run of the default
study (config/config.yaml, constant drive at 50 rad/s, 4 revolutions: settle + revolutions).

Also checks what the smaller file must keep: the impact table of the default-keep file against
that of the dataset in memory, and that two default-keep files combine with
``xarray.open_mfdataset(..., combine="by_coords")``.

Usage: python benchmarks/bench_storage.py [--study]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np
import xarray as xr

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import analysis  # noqa: E402
import simcore  # noqa: E402
from simcore.io import RUN_VARIABLES, STORAGE, write_netcdf  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def _bytes(ds, folder, name, keep):
    return os.path.getsize(write_netcdf(ds, Path(folder) / name, keep=keep))


def per_variable(ds, folder):
    """Bytes each data variable adds to a file of the coordinates and attributes alone."""
    base = ds.drop_vars(list(ds.data_vars))
    b = _bytes(base, folder, "base.nc", None)
    out = {"(coordinates, attributes)": b}
    for name in ds.data_vars:
        out[name] = _bytes(base.assign({name: ds[name]}), folder, "one.nc", None) - b
    return out


def report(label, cfg, folder, details=True):
    ds = simcore.run(cfg)
    keep = cfg["study"]["keep"]
    default = _bytes(ds, folder, "default.nc", keep)
    every = _bytes(ds, folder, "all.nc", list(RUN_VARIABLES))
    print(f"{label}: {ds.sizes['time']} samples; default study.keep {default:,} bytes, "
          f"all variables {every:,} bytes")
    if details:
        for name, size in per_variable(ds, folder).items():
            kept = "kept" if name in keep else ("" if name.startswith("(") else "optional")
            print(f"  {name:26s} {STORAGE.get(name, ''):8s} {size:>10,}  {kept}")
    return ds, Path(folder) / "default.nc"


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--study", action="store_true", help="also a run of the default study")
    args = p.parse_args(argv)
    with tempfile.TemporaryDirectory() as folder:
        cfg = simcore.load_config()
        ds, path = report("paper case (0.3 s, h = 1e-4 s)", cfg, folder)
        with xr.open_dataset(path) as f:
            back = f.load()
        ref, got = analysis.extract_impacts(ds), analysis.extract_impacts(back)
        print(f"impact table from the default file: {got.sizes['impact']} impacts "
              f"(in memory {ref.sizes['impact']})")
        if ref.sizes["impact"] == got.sizes["impact"]:
            for name in ("time", "contact", "kind", "flags", "impulse", "v_pre", "F_max"):
                a = np.asarray(ref[name].values, float)
                b = np.asarray(got[name].values, float)
                ok = np.isfinite(a)
                same_nan = np.array_equal(ok, np.isfinite(b))
                rel = float(np.max(np.abs(a[ok] - b[ok]) / np.maximum(np.abs(a[ok]), 1e-300),
                                   initial=0.0))
                print(f"  {name:8s} largest relative difference {rel:.2g}"
                      f"{'' if same_nan else ' (NaN pattern differs!)'}")
        other = simcore.run(simcore.load_config(overrides=["model.clearance=1e-4"]))
        second = Path(folder) / "clearance~1e-4.nc"
        write_netcdf(other, second, keep=cfg["study"]["keep"])
        first = Path(folder) / "clearance~4e-4.nc"
        os.replace(path, first)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FutureWarning)
            with xr.open_mfdataset([str(first), str(second)], combine="by_coords") as grid:
                print(f"open_mfdataset of two default files: {dict(grid.sizes)}")
        if args.study:
            study = simcore.config.read_study_config([ROOT / "config" / "config.yaml"])
            run = {"model": study["model"], "solver": dict(study["solver"]),
                   "study": study["study"]}
            revs = study["analysis"]["settle"] + study["study"]["revolutions"]
            run["solver"]["t_end"] = revs * 2 * math.pi / abs(run["model"]["omega0"])
            report(f"default study run ({revs:g} revolutions at {run['model']['omega0']:g} "
                   "rad/s)", simcore.validate_config(run), folder, details=False)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
