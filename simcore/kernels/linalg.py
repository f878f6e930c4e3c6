"""Dense linear algebra on the mass-like matrices of the steps."""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def block_inverse(A):
    """Inverse of a matrix that is diagonal outside the rows/columns coupled by off-diagonal
    entries (M + h^2 K: only the bodies joined by springs or contacts are coupled). Only the
    coupled block goes to LAPACK; for the bearing that is 16 x 16 instead of 33 x 33."""
    n = A.shape[0]
    coupled = np.zeros(n, dtype=np.bool_)
    for i in range(n):
        for j in range(n):
            if i != j and A[i, j] != 0.0:
                coupled[i] = True
                coupled[j] = True
    idx = np.nonzero(coupled)[0]
    out = np.zeros((n, n))
    for i in range(n):
        if not coupled[i]:
            out[i, i] = 1.0 / A[i, i]
    k = idx.shape[0]
    if k > 0:
        sub = np.empty((k, k))
        for a in range(k):
            for b in range(k):
                sub[a, b] = A[idx[a], idx[b]]
        inv = np.linalg.inv(sub)
        for a in range(k):
            for b in range(k):
                out[idx[a], idx[b]] = inv[a, b]
    return out
