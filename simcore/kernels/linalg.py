"""Small dense linear algebra written for the sizes of a step (a few to a few dozen unknowns).

LAPACK through ``np.linalg`` costs 7-20 µs a call on these sizes, mostly call overhead and
workspace allocation; the loops below do the same arithmetic in a fraction of that and write
into work arrays made once per run. Every routine works on the leading ``n x n`` block of its
arrays, so one work array serves problems of any size up to its own.

- :func:`cholesky_factor` / :func:`cholesky_solve`: A = L L^T of a symmetric positive definite
  matrix (the metrics M + h^2 K_s, M + h C and the Delassus blocks);
- :func:`lu_factor` / :func:`lu_solve`: P A = L U with partial pivoting (the unsymmetric
  semismooth Newton matrices);
- :func:`block_factor` / :func:`block_solve`: a matrix that is diagonal outside the rows and
  columns coupled by off-diagonal entries (the bearing: only the ball centres joined by the
  cage springs, plus the races of the contacts carrying a geometric stiffness), factorised on
  its coupled block only (Cholesky, LU if the block is not positive definite);
- :func:`block_gram`, :func:`block_gram_rows`, :func:`block_gram_entry`: Delassus matrices
  G A^-1 G^T from such a factor and the rows' supports;
- :func:`saddle_point_solve_into`: the joints' saddle-point systems of the smooth stages and
  of the initial acceleration.

A singular matrix raises ``numpy.linalg.LinAlgError`` like ``np.linalg.solve`` does.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from .jit import inline_kernel, step_kernel

#: ``symmetric`` flags of :func:`block_factor`. NumPy booleans, not Python ones: Numba types a
#: Python constant argument as a literal and compiles a specialisation per value.
SYMMETRIC = np.bool_(True)
GENERAL = np.bool_(False)

#: A matrix factorised on its coupled block (see :func:`block_factor`): ``B`` holds the
#: factors of the coupled block, ``idx[:k]`` the coupled indices, ``dinv`` the inverse
#: diagonal of the others, ``piv`` the LU pivots, ``tmp`` a gather buffer and
#: ``info = (k, mode)`` with mode 0 Cholesky, 1 LU.
BlockFactor = namedtuple("BlockFactor", ["B", "idx", "dinv", "piv", "tmp", "info"])


@step_kernel
def copy_vector(dst, src, n):
    """dst[:n] = src[:n] (an explicit loop: an array assignment would compile Numba's
    shape-mismatch error path, several seconds of compile time for nothing)."""
    for i in range(n):
        dst[i] = src[i]


@step_kernel
def copy_matrix(dst, src, m, n):
    """dst[:m, :n] = src[:m, :n] (see :func:`copy_vector`)."""
    for i in range(m):
        for j in range(n):
            dst[i, j] = src[i, j]


@step_kernel
def cholesky_factor(A, n):
    """Overwrite the lower triangle of ``A[:n, :n]`` with L, A = L L^T.

    Returns False (``A`` partly overwritten) if the matrix is not numerically positive
    definite."""
    for j in range(n):
        s = A[j, j]
        for p in range(j):
            s -= A[j, p] * A[j, p]
        if not s > 0.0:
            return False
        d = np.sqrt(s)
        A[j, j] = d
        for i in range(j + 1, n):
            s = A[i, j]
            for p in range(j):
                s -= A[i, p] * A[j, p]
            A[i, j] = s / d
    return True


@step_kernel
def cholesky_solve(L, n, x):
    """Solve L L^T y = x in place (``L`` from :func:`cholesky_factor`)."""
    for i in range(n):
        s = x[i]
        for p in range(i):
            s -= L[i, p] * x[p]
        x[i] = s / L[i, i]
    for i in range(n - 1, -1, -1):
        s = x[i]
        for p in range(i + 1, n):
            s -= L[p, i] * x[p]
        x[i] = s / L[i, i]


@step_kernel
def lu_factor(A, n, piv):
    """Overwrite ``A[:n, :n]`` with its LU factors (unit lower L), row pivots in ``piv``.

    Raises ``numpy.linalg.LinAlgError`` on an exactly singular matrix."""
    for j in range(n):
        p = j
        big = abs(A[j, j])
        for i in range(j + 1, n):
            if abs(A[i, j]) > big:
                big = abs(A[i, j])
                p = i
        piv[j] = p
        if big == 0.0 or not np.isfinite(big):
            raise np.linalg.LinAlgError("Matrix is singular to machine precision.")
        if p != j:
            for c in range(n):
                tmp = A[j, c]
                A[j, c] = A[p, c]
                A[p, c] = tmp
        inv = 1.0 / A[j, j]
        for i in range(j + 1, n):
            lij = A[i, j] * inv
            A[i, j] = lij
            if lij != 0.0:
                for c in range(j + 1, n):
                    A[i, c] -= lij * A[j, c]


@step_kernel
def lu_solve(LU, n, piv, x):
    """Solve A y = x in place from the factors of :func:`lu_factor`."""
    for j in range(n):
        p = piv[j]
        if p != j:
            tmp = x[j]
            x[j] = x[p]
            x[p] = tmp
    for i in range(n):
        s = x[i]
        for p in range(i):
            s -= LU[i, p] * x[p]
        x[i] = s
    for i in range(n - 1, -1, -1):
        s = x[i]
        for p in range(i + 1, n):
            s -= LU[i, p] * x[p]
        x[i] = s / LU[i, i]


def block_factor_work(n):
    """Work arrays of :func:`block_factor` for matrices up to ``n x n`` (plain Python: made
    once per run, outside the kernels)."""
    # every entry is written by block_factor before it is read
    return BlockFactor(np.empty((n, n)), np.empty(n, dtype=np.int64), np.empty(n),
                       np.empty(n, dtype=np.int64), np.empty(n), np.zeros(2, dtype=np.int64))


@step_kernel
def block_factor(A, n, fac, symmetric):
    """Factorise ``A[:n, :n]`` on its coupled block into ``fac``.

    Indices with an off-diagonal entry in their row or column are coupled; the others only
    need their diagonal. With ``symmetric`` the coupled block gets a Cholesky factorisation
    (which reads its lower triangle only), or an LU one if it is not positive definite;
    otherwise an LU one."""
    idx = fac.idx
    dinv = fac.dinv
    B = fac.B
    degree = fac.piv  # coupling counts first, pivots later
    for i in range(n):
        degree[i] = 0
    # off-diagonal non-zeros of each row and column, counted row by row in contiguous loops
    # that the compiler vectorises (this scan of all n^2 entries is a good part of a
    # factorisation's cost at these sizes)
    for i in range(n):
        in_row = 0
        for j in range(n):
            nz = A[i, j] != 0.0
            in_row += nz
            degree[j] += nz
        diagonal = A[i, i] != 0.0
        degree[i] += in_row - 2 * diagonal
    k = np.int64(0)  # not a literal 0: that would compile a second cholesky/lu specialisation
    for i in range(n):
        if degree[i] != 0:
            # least coupled first (the balls before the races they all touch): the factor
            # then keeps the sparsity of the constraint rows at its start, which the forward
            # substitution of block_gram skips
            a = k
            while a > 0 and degree[idx[a - 1]] > degree[i]:
                idx[a] = idx[a - 1]
                a -= 1
            idx[a] = i
            k += 1
            dinv[i] = 0.0
        else:
            if A[i, i] == 0.0:
                raise np.linalg.LinAlgError("Matrix is singular to machine precision.")
            dinv[i] = 1.0 / A[i, i]
    for a in range(k):
        for c in range(k):
            B[a, c] = A[idx[a], idx[c]]
    mode = 0
    if not symmetric or not cholesky_factor(B, k):
        for a in range(k):
            for c in range(k):
                B[a, c] = A[idx[a], idx[c]]
        lu_factor(B, k, fac.piv)
        mode = 1
    fac.info[0] = k
    fac.info[1] = mode
    return k


@step_kernel
def block_solve(fac, n, x):
    """Solve A y = x in place with the factors of :func:`block_factor` (``x`` of length n)."""
    k = fac.info[0]
    idx = fac.idx
    tmp = fac.tmp
    dinv = fac.dinv
    nonzero = False
    for a in range(k):
        tmp[a] = x[idx[a]]
        nonzero = nonzero or tmp[a] != 0.0
    # a right-hand side without coupled entries (a joint row that touches no ball, say) has a
    # zero coupled solution: no substitution needed
    if nonzero:
        if fac.info[1] == 0:
            cholesky_solve(fac.B, k, tmp)
        else:
            lu_solve(fac.B, k, fac.piv, tmp)
    for i in range(n):
        x[i] *= dinv[i]
    for a in range(k):
        x[idx[a]] = tmp[a]


@step_kernel
def _substitute_row(fac, G, r, Y, yr):
    """Y[yr, :k] = the coupled columns of row r of G through the factor of
    :func:`block_factor`: L^-1 G_c^T for a Cholesky factor (starting at the row's first
    non-zero, which is returned), A_c^-1 G_c^T for an LU one (returns 0). (Rows are addressed
    by index, not passed as views: a view costs two atomic reference-count updates.)"""
    k = fac.info[0]
    idx = fac.idx
    B = fac.B
    f = k
    for a in range(k):
        Y[yr, a] = G[r, idx[a]]
        if f == k and Y[yr, a] != 0.0:
            f = a
    if fac.info[1] != 0:
        if f < k:  # (a row without coupled entries has a zero solution)
            tmp = fac.tmp
            for a in range(k):
                tmp[a] = Y[yr, a]
            lu_solve(B, k, fac.piv, tmp)
            for a in range(k):
                Y[yr, a] = tmp[a]
        return 0
    for a in range(f, k):
        s = Y[yr, a]
        for p in range(f, a):
            s -= B[a, p] * Y[yr, p]
        Y[yr, a] = s / B[a, a]
    return f


@step_kernel
def block_gram(fac, G, m, Y, first, D, cols, ncols):
    """D[:m, :m] = G[:m] A^-1 G[:m]^T for a symmetric A factorised by :func:`block_factor`.

    With a Cholesky factor only the forward substitution Y = L^-1 G_c^T is needed (the
    coupled columns of G), D = Y^T Y, and it starts at each row's first non-zero (``first``
    records it); the uncoupled columns add G_u diag(A_u)^-1 G_u^T over each row's support
    ``cols[r, :ncols[r]]`` (every non-zero of row r is among those columns). ``Y``: work array
    of at least m x k, ``first``: of length m."""
    for r in range(m):
        first[r] = _substitute_row(fac, G, r, Y, r)
    for a in range(m):
        for b in range(a, m):
            D[a, b] = _gram_entry(fac, G, Y, first, cols, ncols, a, b)
    for a in range(m):
        for b in range(a + 1, m):
            D[b, a] = D[a, b]


@inline_kernel
def _gram_entry(fac, G, Y, first, cols, ncols, a, b):
    """Entry (a, b) of D = G A^-1 G^T (see :func:`block_gram`) from the forward
    substitutions of rows a and b of G (``Y[a]``, ``Y[b]``, starting at ``first``): the
    coupled part, then the uncoupled columns of row a's support ``cols[a, :ncols[a]]``."""
    k = fac.info[0]
    s = 0.0
    if fac.info[1] == 0:
        for p in range(max(first[a], first[b]), k):
            s += Y[a, p] * Y[b, p]
    else:
        idx = fac.idx
        for p in range(k):
            s += G[a, idx[p]] * Y[b, p]
    dinv = fac.dinv
    for t in range(ncols[a]):  # the uncoupled columns of row a's support
        i = cols[a, t]
        s += G[a, i] * dinv[i] * G[b, i]
    return s


@step_kernel
def block_gram_rows(fac, G, rows, m, Y, first, have, D, cols, ncols):
    """Entries of D = G A^-1 G^T (see :func:`block_gram`) among the rows ``rows[:m]`` of G,
    computed only where missing: a row r not yet marked in ``have`` gets its forward
    substitution (kept in ``Y[r]``, ``first[r]``) and its entries with every marked row
    (itself included). A caller that grows its row set one row at a time thus pays for the new
    row only. Clear ``have`` whenever A or G change. ``D``: the full G.shape[0]-square cache;
    ``cols``/``ncols``: the rows' supports."""
    for a in range(m):
        r = rows[a]
        if have[r]:
            continue
        have[r] = True
        first[r] = _substitute_row(fac, G, r, Y, r)
        for rb in range(G.shape[0]):
            if not have[rb]:
                continue
            s = _gram_entry(fac, G, Y, first, cols, ncols, r, rb)
            D[r, rb] = s
            D[rb, r] = s


@step_kernel
def block_gram_entry(fac, G, r, Y, yr, cols, c, m):
    """G_r A^-1 G_r^T for row r of G (see :func:`block_gram`), whose support is
    ``cols[c, :m]``; ``Y[yr]`` is the work row of the substitution."""
    k = fac.info[0]
    idx = fac.idx
    dinv = fac.dinv
    f = _substitute_row(fac, G, r, Y, yr)
    s = 0.0
    if fac.info[1] == 0:
        for a in range(f, k):
            s += Y[yr, a] * Y[yr, a]
    else:
        for a in range(k):
            s += G[r, idx[a]] * Y[yr, a]
    for t in range(m):
        i = cols[c, t]
        s += G[r, i] * G[r, i] * dinv[i]
    return s


@step_kernel
def saddle_point_solve_into(J, G, c, rhs, fac, JG, S, piv):
    """Solve [J, -G^T; c G, 0] [x; y] = rhs in place (``rhs[:n]`` becomes x, ``rhs[n:]``
    becomes y) by the Schur complement S = c G J^-1 G^T of the m constraint rows.

    ``J`` (n x n) is factorised on its coupled block (:func:`block_factor`, LU: J need not be
    symmetric); ``G`` is m x n, ``c`` a scalar. Work arrays: ``fac`` (:func:`block_factor_work`
    of n), ``JG`` (m x n), ``S`` (m x m), ``piv`` (m integers)."""
    n = J.shape[0]
    m = G.shape[0]
    block_factor(J, n, fac, GENERAL)
    x = rhs[:n]
    block_solve(fac, n, x)
    if m == 0:
        return
    y = rhs[n:]
    for r in range(m):
        row = JG[r]
        for i in range(n):
            row[i] = G[r, i]
        block_solve(fac, n, row)
    for a in range(m):
        for b in range(m):
            S[a, b] = 0.0
    for a in range(m):
        s = 0.0
        for i in range(n):
            g = G[a, i]
            if g != 0.0:
                s += g * x[i]
                for b in range(m):
                    S[a, b] += c * g * JG[b, i]
        y[a] -= c * s
    lu_factor(S, m, piv)
    lu_solve(S, m, piv, y)
    add_transposed_product(x, x, JG, y)


@step_kernel
def add_transposed_product(x, b, A, y):
    """x = b + A^T y (``x``, ``b``: n; ``A``: m x n; ``y``: m), each entry summed in the order
    of A's rows; ``x`` may be ``b``."""
    for i in range(x.shape[0]):
        s = b[i]
        for a in range(A.shape[0]):
            s += A[a, i] * y[a]
        x[i] = s
