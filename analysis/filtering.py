"""The impulse filter of the paper (section 3; docs/forces.md).

Each ball-race contact yields, at every time step, a discrete normal impulse Λ_n [N s]. The filter
splits that series into three parts that add up to Λ exactly:

* Λ_FI, the *simple* (isolated) impacts: Λ_FI,n = Λ_n where Λ_{n-1} and Λ_{n+1} are "zero" and
  Λ_n is not; 0 elsewhere.
* Λ_S, the *smooth* part (persistent contact force × h): on Λ_AUX = Λ - Λ_FI, wherever Λ_AUX has
  an upward single-sample peak (Λ_AUX,n > Λ_AUX,n-1 and Λ_AUX,n > Λ_AUX,n+1) Λ_S,n is the mean of
  the two neighbours; elsewhere Λ_S,n = Λ_AUX,n.
* Λ_FIsuv = Λ_AUX - Λ_S, the impacts on top of persistent contact.

"Zero" means at or below a threshold ``max(zero_tol * scale, floor)``, where ``scale`` is the run's
largest Λ_N unless given (see :func:`zero_threshold`).

End samples
-----------
The first and the last sample have a single neighbour. The code takes the missing neighbour equal
to the sample itself (edge replication): an end sample is therefore never a simple impact nor an
upward peak, and goes whole into Λ_S. At t = 0 this changes nothing (Λ_0 = 0 by definition); at
the last step an impact whose continuation is unknown is not counted. Zero-length and one-sample
series return all-zero Λ_FI and Λ_FIsuv and Λ_S = Λ.

Other choices
-------------
* A sample that is a simple impact is not also tested as a peak of Λ_AUX (there Λ_AUX = 0 and
  can only be a "peak" over negative neighbours, i.e. numerical noise below zero).
* The filter is one pass, as in the paper: replacing a peak by the mean of its neighbours may
  leave new, smaller peaks beside it, which are not filtered again.
* The last sample of a train that rises until separation exceeds both neighbours (the next is
  zero) and so reads as an upward peak: the rule gives it Λ_FIsuv > 0 there. That is the paper's
  rule, kept; such a "peak" is usually an end of contact, not an impact.
* Exactness: Λ_FIsuv is computed as Λ_AUX - mean and Λ_S then re-derived as Λ_AUX - Λ_FIsuv; for
  Λ >= 0 Sterbenz' lemma makes the second subtraction exact, so ``(lam_fi + lam_s) + lam_fisuv
  == lam`` holds bit for bit, not just to rounding. With negative values (numerical noise below
  zero; Λ_N >= 0 by construction) a peak whose split would not be exact is left unsmoothed, so the
  identity holds for any finite input.
"""

from __future__ import annotations

import numpy as np
import xarray as xr
from numba import njit

from ._checks import positive

__all__ = ["split_impulses", "split_dataset", "zero_threshold", "impact_masks"]


@njit(cache=True)
def _split_kernel(lam, thr, fi, s, fisuv):
    """Filter every row of the 2-d array ``lam`` (rows, time) in one pass.

    Parameters
    ----------
    lam : ndarray, shape (m, n), float64
        Impulse series [N s], one per row.
    thr : float
        Zero threshold [N s]: values ``<= thr`` count as zero.
    fi, s, fisuv : ndarray, shape (m, n), float64
        Outputs (written in place): Λ_FI, Λ_S and Λ_FIsuv.
    """
    m, n = lam.shape
    for r in range(m):
        # sliding window over Λ_AUX: previous, current, next (edge-replicated)
        for k in range(n):
            lk = lam[r, k]
            lp = lam[r, k - 1] if k > 0 else lk
            ln = lam[r, k + 1] if k < n - 1 else lk
            if k > 0 and k < n - 1 and lk > thr and lp <= thr and ln <= thr:
                fi[r, k] = lk
            else:
                fi[r, k] = 0.0
        for k in range(n):
            if fi[r, k] != 0.0:
                # simple impact: Λ_AUX = 0 here, not a peak
                s[r, k] = 0.0
                fisuv[r, k] = 0.0
                continue
            a = lam[r, k]  # Λ_AUX,n (Λ_FI,n = 0)
            if k == 0 or k == n - 1:
                s[r, k] = a
                fisuv[r, k] = 0.0
                continue
            ap = lam[r, k - 1] - fi[r, k - 1]
            an = lam[r, k + 1] - fi[r, k + 1]
            if a > ap and a > an:
                mean = 0.5 * (ap + an)
                d = a - mean
                sk = a - d  # exact (Sterbenz) when the neighbours are >= 0
                if sk + d == a:
                    s[r, k] = sk
                    fisuv[r, k] = d
                else:  # only possible with (noise) negative neighbours: leave unsmoothed
                    s[r, k] = a
                    fisuv[r, k] = 0.0
            else:
                s[r, k] = a
                fisuv[r, k] = 0.0


def zero_threshold(lam=None, zero_tol=1e-4, floor=1e-12, scale=None) -> float:
    """The zero threshold of the filter [N s].

    Parameters
    ----------
    lam : array_like, optional
        Impulses [N s]; used for the scale when ``scale`` is not given.
    zero_tol : float
        Relative threshold [-], ``0 <= zero_tol < 1``.
    floor : float
        Absolute floor [N s], ``>= 0``.
    scale : float, optional
        Reference impulse [N s]. Default: the largest value of ``lam`` (the whole array, so
        passing one run's ``[contact, time]`` array gives "the run's largest Λ_N").

    Returns
    -------
    float
        ``max(zero_tol * scale, floor)``; impulses at or below it count as zero.
    """
    zero_tol = positive("zero_tol", zero_tol, allow_zero=True)
    if zero_tol >= 1.0:
        raise ValueError(f"zero_tol must be in [0, 1), got {zero_tol!r}")
    floor = positive("floor", floor, allow_zero=True)
    if scale is None:
        if lam is None:
            raise ValueError("zero_threshold needs lam or scale")
        arr = np.asarray(lam, dtype=float)
        scale = float(np.max(arr)) if arr.size else 0.0
        scale = max(scale, 0.0)
    else:
        scale = positive("scale", scale, allow_zero=True)
    return max(zero_tol * scale, floor)


def split_impulses(lam, zero_tol=1e-4, floor=1e-12, scale=None):
    """Split impulse series into simple impacts, smooth part and impacts on persistent contact.

    Works along the **last** axis of an array of any shape (e.g. all contacts of all runs at
    once). Run data has dims ``(time, contact)``: transpose it first (``lam.T``).

    Parameters
    ----------
    lam : array_like
        Discrete normal impulses Λ [N s], time along the last axis. Must be finite.
    zero_tol : float
        Relative zero threshold [-] (docs/forces.md, default 1e-4).
    floor : float
        Absolute floor of the threshold [N s] (default 1e-12).
    scale : float, optional
        Reference impulse for the relative threshold [N s]. Default: the maximum of the whole
        array passed. Pass it explicitly to filter several runs at once, each with its own
        threshold being impossible in one call: use one call per run, or a common scale.

    Returns
    -------
    lam_fi, lam_s, lam_fisuv : ndarray
        Λ_FI, Λ_S and Λ_FIsuv [N s], float64, same shape as ``lam``;
        ``(lam_fi + lam_s) + lam_fisuv == lam`` exactly. End samples: see the module docstring
        (the missing neighbour is taken equal to the sample, so end samples go into Λ_S). At a
        peak Λ_S equals the mean of the neighbours to within one rounding unit of Λ_n.

    Raises
    ------
    ValueError
        If ``lam`` contains NaN or infinities, or a setting is out of range.

    Notes
    -----
    Values ``<= threshold`` count as zero, with threshold ``= max(zero_tol * scale, floor)``
    (:func:`zero_threshold`). Λ_FI is non-zero only at samples whose both neighbours are zero.
    Λ_FIsuv is non-zero only at upward single-sample peaks of Λ_AUX; tiny ripples of a persistent
    contact train also give tiny Λ_FIsuv, so count impacts on persistent contact only where
    Λ_FIsuv exceeds the threshold too (:func:`impact_masks`).
    """
    arr = np.asarray(lam, dtype=np.float64)
    if arr.ndim == 0:
        raise ValueError("lam must have at least one dimension (time along the last axis)")
    if arr.size and not np.all(np.isfinite(arr)):
        raise ValueError("lam contains NaN or infinite values")
    thr = zero_threshold(arr, zero_tol, floor, scale)
    shape = arr.shape
    n = shape[-1]
    if arr.size == 0:
        return arr.copy(), arr.copy(), arr.copy()
    flat = np.ascontiguousarray(arr.reshape(-1, n))
    fi = np.empty_like(flat)
    s = np.empty_like(flat)
    fisuv = np.empty_like(flat)
    _split_kernel(flat, thr, fi, s, fisuv)
    return fi.reshape(shape), s.reshape(shape), fisuv.reshape(shape)


def impact_masks(lam_fi, lam_fisuv, threshold):
    """Boolean masks of the counted impacts.

    Parameters
    ----------
    lam_fi, lam_fisuv : ndarray
        Outputs of :func:`split_impulses` [N s].
    threshold : float
        Zero threshold [N s] (:func:`zero_threshold`).

    Returns
    -------
    simple, persistent : ndarray of bool
        ``lam_fi > threshold`` and ``lam_fisuv > threshold``.
    """
    return np.asarray(lam_fi) > threshold, np.asarray(lam_fisuv) > threshold


def split_dataset(run_ds: xr.Dataset, zero_tol=1e-4, zero_floor=1e-12) -> xr.Dataset:
    """Apply the filter to every contact of one run.

    Parameters
    ----------
    run_ds : xarray.Dataset
        One run file's dataset, with ``Lambda_N`` (time, contact) [N s].
    zero_tol : float
        Relative zero threshold [-]; the scale is the run's largest Λ_N.
    zero_floor : float
        Absolute floor of the threshold [N s].

    Returns
    -------
    xarray.Dataset
        ``Lambda_FI``, ``Lambda_S``, ``Lambda_FIsuv`` (time, contact) [N s] with the run's
        coordinates (including scalar ones); attrs ``zero_tol``, ``zero_floor``,
        ``zero_threshold`` [N s], ``lambda_scale`` [N s] and the counts ``n_simple``,
        ``n_persistent`` (impulses above the threshold).
    """
    if "Lambda_N" not in run_ds:
        raise ValueError("run_ds has no variable 'Lambda_N'")
    lam_da = run_ds["Lambda_N"].transpose(..., "time")
    lam = np.asarray(lam_da.values, dtype=float)
    scale = float(np.max(lam)) if lam.size else 0.0
    scale = max(scale, 0.0)
    thr = zero_threshold(scale=scale, zero_tol=zero_tol, floor=zero_floor)
    fi, s, fisuv = split_impulses(lam, zero_tol, zero_floor, scale=scale)
    simple, persistent = impact_masks(fi, fisuv, thr)
    dims = lam_da.dims
    coords = {k: v for k, v in lam_da.coords.items()}
    note = f"zero threshold {thr:.6g} N s = max({zero_tol:g} x {scale:.6g} N s, {zero_floor:g} N s)"
    out = xr.Dataset(
        {
            "Lambda_FI": (dims, fi, {"units": "N s",
                                     "long_name": "simple (isolated) impact impulse",
                                     "comment": note}),
            "Lambda_S": (dims, s, {"units": "N s",
                                   "long_name": "smooth impulse (persistent contact force x h)",
                                   "comment": note}),
            "Lambda_FIsuv": (dims, fisuv, {"units": "N s",
                                           "long_name": "impact impulse on persistent contact",
                                           "comment": note}),
        },
        coords=coords,
    )
    out = out.transpose("time", ...)
    out.attrs.update({
        "zero_tol": float(zero_tol),
        "zero_floor": float(zero_floor),
        "zero_threshold": float(thr),
        "zero_threshold_units": "N s",
        "lambda_scale": scale,
        "n_simple": int(simple.sum()),
        "n_persistent": int(persistent.sum()),
        "filter": "Sanchez, Cardona, Cavalieri, section 3; end samples edge-replicated",
    })
    return out
