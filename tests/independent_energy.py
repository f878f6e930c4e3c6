"""A run's energy and the energy audit's scale recomputed apart from the kernels, from the
stored positions and velocities (``benchmarks/fuzz_corners.py``'s, which its fuzzing uses)."""

from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
try:
    from fuzz_corners import (
        independent_energy,
        independent_energy_parts,
        independent_energy_scale,
    )
finally:
    sys.path.pop(0)

__all__ = ["independent_energy", "independent_energy_parts", "independent_energy_scale"]
