"""Checks of the analysis' scalar inputs, with the one-line error the tool gives for bad input."""

from __future__ import annotations

import math


def positive(name: str, value, allow_zero: bool = False) -> float:
    """``value`` as a float, or a ``ValueError`` naming ``name`` and what is allowed.

    Parameters
    ----------
    name : str
        Name of the input, as the error states it.
    value : float-like
        The input (in the unit of its parameter).
    allow_zero : bool
        Accept 0 too (a finite number >= 0); otherwise > 0.

    Returns
    -------
    float
    """
    allowed = ">= 0" if allow_zero else "> 0"
    try:
        number = float(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: {value!r} is not allowed; allowed: a finite number "
                         f"{allowed}") from exc
    if not math.isfinite(number) or number < 0.0 or (number == 0.0 and not allow_zero):
        raise ValueError(f"{name}: {number!r} is not allowed; allowed: a finite number {allowed}")
    return number


def poisson_ratio(name: str, value) -> float:
    """``value`` as a float Poisson ratio in (-1, 0.5), or a ``ValueError`` naming ``name``."""
    try:
        number = float(value)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name}: {value!r} is not allowed; allowed: a Poisson ratio in "
                         "(-1, 0.5)") from exc
    if not math.isfinite(number) or not (-1.0 < number < 0.5):
        raise ValueError(f"{name}: {number!r} is not allowed; allowed: a Poisson ratio in "
                         "(-1, 0.5)")
    return number
