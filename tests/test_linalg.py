"""The hand-written small dense algebra of the step against numpy.linalg, on random matrices
of the step's sizes (symmetric positive definite, general, block-structured), and the velocity
problem's solver against the complementarity conditions it must meet."""

from pathlib import Path

import numpy as np
import pytest

from simcore.kernels import linalg as la
from simcore.kernels.nonsmooth_step import solve_velocity_problem


def _spd(rng, n):
    a = rng.standard_normal((n, n))
    return a @ a.T + n * np.eye(n)


def _block_structured(rng, n, coupled, symmetric=True):
    """Diagonal matrix with a dense block on the indices ``coupled`` (like M + h^2 K)."""
    A = np.diag(rng.uniform(1.0, 3.0, n))
    k = len(coupled)
    B = _spd(rng, k) if symmetric else rng.standard_normal((k, k)) + 2 * k * np.eye(k)
    A[np.ix_(coupled, coupled)] = B
    return A


@pytest.mark.parametrize("n", [1, 6, 16, 39])
def test_cholesky_matches_numpy(n):
    rng = np.random.default_rng(n)
    A = _spd(rng, n)
    b = rng.standard_normal(n)
    # a larger work array: only its leading n x n block is used
    work = np.full((n + 3, n + 3), np.nan)
    work[:n, :n] = A
    assert la.cholesky_factor(work, n)
    np.testing.assert_allclose(np.tril(work[:n, :n]), np.linalg.cholesky(A), rtol=1e-12,
                               atol=1e-12)
    x = b.copy()
    la.cholesky_solve(work, n, x)
    np.testing.assert_allclose(x, np.linalg.solve(A, b), rtol=1e-10, atol=1e-12)


def test_cholesky_rejects_an_indefinite_matrix():
    A = np.diag([1.0, -1.0, 2.0])
    assert not la.cholesky_factor(A.copy(), 3)


@pytest.mark.parametrize("n", [1, 5, 22, 38])
def test_lu_matches_numpy(n):
    rng = np.random.default_rng(100 + n)
    A = rng.standard_normal((n, n))
    if n > 1:
        A[0, 0] = 0.0  # needs pivoting
    b = rng.standard_normal(n)
    LU = A.copy()
    piv = np.zeros(n, dtype=np.int64)
    la.lu_factor(LU, n, piv)
    x = b.copy()
    la.lu_solve(LU, n, piv, x)
    np.testing.assert_allclose(x, np.linalg.solve(A, b), rtol=1e-9, atol=1e-10)


def test_lu_raises_on_a_singular_matrix():
    A = np.array([[1.0, 2.0], [2.0, 4.0]])
    A[1] -= 2.0 * A[0]  # exactly singular
    with pytest.raises(np.linalg.LinAlgError):
        la.lu_factor(A, 2, np.zeros(2, dtype=np.int64))


@pytest.mark.parametrize("symmetric", [True, False])
def test_block_factor_and_solve(symmetric):
    rng = np.random.default_rng(7)
    n = 33
    coupled = [9, 10, 12, 13, 15, 16, 30, 31]
    A = _block_structured(rng, n, coupled, symmetric)
    fac = la.block_factor_work(n)
    k = la.block_factor(A, n, fac, symmetric)
    assert k == len(coupled) and sorted(fac.idx[:k]) == coupled
    assert fac.info[1] == (0 if symmetric else 1)
    b = rng.standard_normal(n)
    x = b.copy()
    la.block_solve(fac, n, x)
    np.testing.assert_allclose(x, np.linalg.solve(A, b), rtol=1e-10, atol=1e-12)


def test_block_factor_falls_back_to_lu_on_an_indefinite_block():
    rng = np.random.default_rng(8)
    n = 12
    A = np.diag(rng.uniform(1.0, 2.0, n))
    A[3, 3], A[3, 7], A[7, 3], A[7, 7] = 1.0, 2.0, 2.0, 1.0  # eigenvalues 3 and -1
    fac = la.block_factor_work(n)
    la.block_factor(A, n, fac, True)
    assert fac.info[1] == 1
    b = rng.standard_normal(n)
    x = b.copy()
    la.block_solve(fac, n, x)
    np.testing.assert_allclose(x, np.linalg.solve(A, b), rtol=1e-10)


def _supports(G):
    """The rows' supports (their non-zero columns), as the kernels' ``cols``/``ncols``."""
    cols = np.zeros(G.shape, dtype=np.int64)
    ncols = np.zeros(G.shape[0], dtype=np.int64)
    for r in range(G.shape[0]):
        nz = np.flatnonzero(G[r])
        cols[r, :nz.size] = nz
        ncols[r] = nz.size
    return cols, ncols


@pytest.mark.parametrize("indefinite", [False, True])
def test_block_gram_is_the_delassus_matrix(indefinite):
    rng = np.random.default_rng(9)
    n, m = 33, 14
    coupled = list(range(9, 25)) + [0, 1, 2]
    A = _block_structured(rng, n, sorted(coupled))
    if indefinite:
        A[0, 0] = -50.0  # still symmetric: the coupled block goes to LU
    G = np.zeros((m, n))
    for r in range(m):  # sparse rows, like joints and contacts
        cols = rng.choice(n, 6, replace=False)
        G[r, cols] = rng.standard_normal(6)
    fac = la.block_factor_work(n)
    la.block_factor(A, n, fac, True)
    assert fac.info[1] == (1 if indefinite else 0)
    D = np.full((m + 2, m + 2), np.nan)
    cols, ncols = _supports(G)
    la.block_gram(fac, G, m, np.zeros((m, n)), np.zeros(m, dtype=np.int64), D, cols, ncols)
    np.testing.assert_allclose(D[:m, :m], G @ np.linalg.solve(A, G.T), rtol=1e-9, atol=1e-12)


def _saddle_point_solve(J, G, c, rhs):
    """saddle_point_solve_into with fresh work arrays (as the time loops' are made)."""
    n, m = J.shape[0], G.shape[0]
    la.saddle_point_solve_into(J, G, c, rhs, la.block_factor_work(n), np.zeros((m, n)),
                               np.zeros((m, m)), np.zeros(m, dtype=np.int64))


def test_saddle_point_solve_matches_the_assembled_system():
    rng = np.random.default_rng(10)
    n, m, c = 33, 6, 0.37
    J = _block_structured(rng, n, list(range(9, 25)), symmetric=False)
    G = np.zeros((m, n))
    for r in range(m):
        G[r, rng.choice(9, 3, replace=False)] = rng.standard_normal(3)
    rhs = rng.standard_normal(n + m)
    K = np.block([[J, -G.T], [c * G, np.zeros((m, m))]])
    x = rhs.copy()
    _saddle_point_solve(J, G, c, x)
    np.testing.assert_allclose(x, np.linalg.solve(K, rhs), rtol=1e-9, atol=1e-12)
    # no constraint rows: a plain solve
    y = rhs[:n].copy()
    _saddle_point_solve(J, np.zeros((0, n)), c, y)
    np.testing.assert_allclose(y, np.linalg.solve(J, rhs[:n]), rtol=1e-10)


@pytest.mark.parametrize("seed", range(6))
def test_velocity_problem_meets_newton_and_coulomb(seed):
    """Random frictional contacts (normal/tangent pairs) on an SPD Delassus matrix: the
    solution satisfies 0 <= xi_N ⊥ Lambda_N >= 0 and Coulomb's law with stick or slip."""
    rng = np.random.default_rng(seed)
    n_contacts = 1 + seed
    m = 2 * n_contacts
    D = _spd(rng, m) / m
    c = rng.standard_normal(m)
    kind = np.tile([1, 2], n_contacts).astype(np.int64)
    mu = np.where(kind == 2, 0.3, 0.0)
    pair = np.where(kind == 2, np.arange(m) - 1, 0).astype(np.int64)
    lam = np.zeros(m)
    tol = 1e-10
    its, ok = solve_velocity_problem(D, c, kind, mu, pair, lam, tol, 50, 0.0)
    assert ok
    xi = D @ lam + c
    lN, lT, xN, xT = lam[0::2], lam[1::2], xi[0::2], xi[1::2]
    assert (lN >= 0.0).all() and (xN >= -1e-8).all()
    np.testing.assert_allclose(lN * xN, 0.0, atol=1e-8)
    assert (np.abs(lT) <= 0.3 * lN + 1e-12).all()
    stick = np.abs(lT) < 0.3 * lN - 1e-8
    np.testing.assert_allclose(xT[stick], 0.0, atol=1e-8)
    slip = ~stick & (lN > 1e-8)
    # sliding: the friction impulse opposes the slip
    assert (lT[slip] * xT[slip] <= 1e-8).all()


PINCHED_RINGS = Path(__file__).parent / "data" / "velocity_problems_pinched_rings.npz"


@pytest.mark.parametrize("problem", ["singular", "pinched"])
def test_newton_after_the_fallback_solves_the_velocity_problems_of_pinched_rings(problem):
    """Two velocity problems on which Newton cycles and Gauss-Seidel stalls above the tolerance
    at every substep of a retried step (velocity jumps of benchmarks/fuzz_corners.py 150 0.05
    11: a 16-ball ring at 0.77 mm, mu 0.13, 132 rad/s, whose Delassus matrix is singular, 38
    rows; a 19-ball ring at 1.3 um, mu 0.47, 333 rad/s, 42 rows; balls pinched between both
    rings). A retried step's Newton from the fallback's iterate solves them: Newton's and
    Coulomb's laws hold to the tolerance, checked here on xi = D lam + c."""
    data = np.load(PINCHED_RINGS)
    D, c, kind, mu, pair, lam0 = (data[f"{problem}_{k}"]
                                  for k in ("D", "c", "kind", "mu_row", "pair", "lam"))
    tol, max_iter, eta = (float(data[f"{problem}_tol"]), int(data[f"{problem}_max_iter"]),
                          float(data[f"{problem}_eta"]))
    assert not solve_velocity_problem(D, c, kind, mu, pair, lam0.copy(), tol, max_iter, eta)[1]
    lam = lam0.copy()
    its, ok = solve_velocity_problem(D, c, kind, mu, pair, lam, tol, max_iter, eta, 1)
    assert ok
    xi = D @ lam + c
    normal, tangent = kind == 1, kind == 2
    lN, xN = lam[normal], xi[normal]
    assert (lN >= 0.0).all() and (xN >= -tol).all()
    assert np.all((lN <= 1e-12 * np.abs(lam).max()) | (np.abs(xN) <= tol))  # complementarity
    lT, xT = lam[tangent], xi[tangent]
    bound = mu[tangent] * lam[pair[tangent]]
    assert (np.abs(lT) <= bound * (1 + 1e-12) + 1e-15).all()
    stick = np.abs(lT) < bound * (1 - 1e-9)
    assert (np.abs(xT[stick]) <= tol).all()
    assert (lT[~stick] * xT[~stick] <= tol * np.abs(lT[~stick])).all()  # opposes the slip


def test_block_gram_entry_is_the_delassus_diagonal():
    rng = np.random.default_rng(11)
    n, m = 20, 9
    A = _block_structured(rng, n, [2, 3, 4, 11, 12])
    G = rng.standard_normal((m, n))
    fac = la.block_factor_work(n)
    la.block_factor(A, n, fac, True)
    cols, ncols = _supports(G)
    Y = np.zeros((3, n))
    # each entry with its substitution in a work row of its own choosing
    d = [la.block_gram_entry(fac, G, r, Y, r % 3, cols, r, ncols[r]) for r in range(m)]
    np.testing.assert_allclose(d, np.diag(G @ np.linalg.solve(A, G.T)), rtol=1e-10)


@pytest.mark.parametrize("indefinite", [False, True])
def test_block_gram_rows_grows_a_row_set(indefinite):
    rng = np.random.default_rng(12)
    n, mt = 33, 22
    A = _block_structured(rng, n, list(range(9, 25)) + [0, 1, 2])
    if indefinite:
        A[0, 0] = -50.0
    G = np.zeros((mt, n))
    for r in range(mt):
        G[r, rng.choice(n, 6, replace=False)] = rng.standard_normal(6)
    fac = la.block_factor_work(n)
    la.block_factor(A, n, fac, True)
    full = G @ np.linalg.solve(A, G.T)
    Y, first = np.zeros((mt, n)), np.zeros(mt, dtype=np.int64)
    have = np.zeros(mt, dtype=np.bool_)
    D = np.full((mt, mt), np.nan)
    for rows in ([0, 1, 5], [0, 1, 5, 9, 17, 21]):
        r = np.array(rows + [0] * (mt - len(rows)), dtype=np.int64)
        la.block_gram_rows(fac, G, r, len(rows), Y, first, have, D, *_supports(G))
        np.testing.assert_allclose(D[np.ix_(rows, rows)], full[np.ix_(rows, rows)], rtol=1e-9,
                                   atol=1e-12)
    assert np.isnan(D[2, 3])  # never asked for
    assert have.sum() == 6


def test_copies():
    src = np.arange(12.0).reshape(3, 4)
    dst = np.zeros((3, 4))
    la.copy_matrix(dst, src, 2, 3)
    np.testing.assert_array_equal(dst[:2, :3], src[:2, :3])
    assert not dst[2].any() and not dst[:, 3].any()
    v = np.zeros(4)
    la.copy_vector(v, src[1], 3)
    np.testing.assert_array_equal(v, [4.0, 5.0, 6.0, 0.0])
