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


@njit(cache=True)
def gauss_solve(A, B):
    """Solve A X = B for a small dense A (k x k) and several right-hand sides B (k x r) by
    Gaussian elimination with partial pivoting, written out (no LAPACK call overhead, which
    dominates at these sizes). A and B are not modified. Raises ZeroDivisionError-free: a zero
    pivot gives inf/nan, which the callers' convergence checks catch."""
    k = A.shape[0]
    r = B.shape[1]
    M = A.copy()
    X = B.copy()
    for c in range(k):
        p = c
        big = abs(M[c, c])
        for i in range(c + 1, k):
            if abs(M[i, c]) > big:
                big = abs(M[i, c])
                p = i
        if p != c:
            for j in range(c, k):
                tmp = M[c, j]
                M[c, j] = M[p, j]
                M[p, j] = tmp
            for j in range(r):
                tmp = X[c, j]
                X[c, j] = X[p, j]
                X[p, j] = tmp
        piv = M[c, c]
        for i in range(c + 1, k):
            fac = M[i, c] / piv
            if fac != 0.0:
                for j in range(c + 1, k):
                    M[i, j] -= fac * M[c, j]
                for j in range(r):
                    X[i, j] -= fac * X[c, j]
    for c in range(k - 1, -1, -1):
        for j in range(r):
            s = X[c, j]
            for i in range(c + 1, k):
                s -= M[c, i] * X[i, j]
            X[c, j] = s / M[c, c]
    return X


@njit(cache=True)
def solve_mass_like(A, B):
    """Solve A X = B where A is diagonal outside the rows/columns coupled by off-diagonal
    entries (M plus the tangents of springs and contacts): the uncoupled rows by division, the
    coupled block by :func:`gauss_solve`. B: (n x r)."""
    n = A.shape[0]
    r = B.shape[1]
    coupled = np.zeros(n, dtype=np.bool_)
    for i in range(n):
        for j in range(i + 1, n):
            if A[i, j] != 0.0 or A[j, i] != 0.0:
                coupled[i] = True
                coupled[j] = True
    X = np.empty((n, r))
    kc = 0
    for i in range(n):
        if coupled[i]:
            kc += 1
        else:
            for j in range(r):
                X[i, j] = B[i, j] / A[i, i]
    if kc > 0:
        idx = np.nonzero(coupled)[0]
        sub = np.empty((kc, kc))
        rhs = np.empty((kc, r))
        for a in range(kc):
            for b in range(kc):
                sub[a, b] = A[idx[a], idx[b]]
            for j in range(r):
                rhs[a, j] = B[idx[a], j]
        sol = gauss_solve(sub, rhs)
        for a in range(kc):
            for j in range(r):
                X[idx[a], j] = sol[a, j]
    return X
