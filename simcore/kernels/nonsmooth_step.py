"""The decoupled nonsmooth generalized-alpha step: after the smooth stage
(:mod:`.generalized_alpha`), a position correction (joints and unilateral contacts) and a
velocity jump (Newton's impact law and Coulomb friction), and the time loop over a chunk of
steps."""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from .bodies import (
    pair_support,
    place_row,
    scale_pair_blocks,
    scatter_row,
    trig_cache,
)
from .contact import contact_hessian_into, contact_rows_cached, contact_velocities_into
from .generalized_alpha import alpha_coefficients, smooth_step, smooth_work, step_work
from .jit import loop_kernel, step_kernel
from .joints import bilateral_cached, joint_support
from .linalg import (
    SYMMETRIC,
    block_factor,
    block_factor_work,
    block_gram,
    block_gram_entry,
    block_gram_rows,
    block_solve,
    copy_matrix,
    copy_vector,
    lu_factor,
    lu_solve,
)
from .springs import FORCES_ONLY, smooth_forces_into, spring_damping_into, total_energy

# layout of the per-step statistics written by integrate_chunk
STAGE_SMOOTH = 0
STAGE_POSITION = 1
STAGE_VELOCITY = 2

#: Work arrays of the position correction (:func:`position_work`).
PositionWork = namedtuple("PositionWork", ["Ap", "facA", "Hm", "facH", "U", "U_new", "U_try",
    "q_try", "HAU", "eq", "nu_b", "nub_new", "nub_try", "gb", "Gb", "gb_try", "Gb_try", "gm",
    "dgdt", "r_c", "GN0", "ys", "nuc_new", "nuc_try", "gap_try", "GN", "GN_try", "active",
    "Hloc", "wN", "wT", "Gall", "ball", "Y", "AU", "first", "have", "x", "Dall", "rows", "Dbuf",
    "sol", "piv", "cols", "ncols", "AU_try", "trig", "P"])

#: Work arrays of the velocity jump (:func:`velocity_work`).
VelocityWork = namedtuple("VelocityWork", ["f1", "C1", "Av", "fac", "b", "Ab",
    "tmp", "wN", "wT", "gb", "gm", "dgdt", "Gb", "closed", "row_of", "G",
    "off", "kind", "mu_row", "pair", "lam", "Y", "first", "D", "c", "Dbb", "pivb",
    "colb", "X", "Dc", "cc", "lam_c", "pair_c", "cols", "ncols", "solver", "trig", "fw",
    "iw"])

#: Work arrays of the velocity problem's Newton solver.
VelocitySolverWork = namedtuple("VelocitySolverWork", ["r", "F", "F_try", "xi", "xi_try",
    "lam_try", "dl", "J", "piv", "branch"])

#: All work arrays of :func:`integrate_chunk` (:func:`nonsmooth_work`): the step's
#: (:func:`~.generalized_alpha.step_work`), the smooth stage's, the position correction's,
#: the velocity jump's, and the contacts' (multipliers nu_N, gaps, normal and tangential
#: velocities after the step and normal velocities before the jump, one entry per contact).
NonsmoothWork = namedtuple("NonsmoothWork", ["step", "smooth", "position", "velocity",
                                             "contact"])


def position_work(n, nbil, nc, trig=None):
    """Work arrays of :func:`position_step` (made once per run, in Python: allocating them in
    a kernel would compile some forty array constructors into every time loop). ``trig``: the
    bodies' sine/cosine cache (:func:`~.bodies.trig_cache`), shared with the velocity jump."""
    mt = nbil + nc
    return PositionWork(
        Ap=np.zeros((n, n)), facA=block_factor_work(n), Hm=np.zeros((n, n)),
        facH=block_factor_work(n), U=np.zeros(n), U_new=np.zeros(n), U_try=np.zeros(n),
        q_try=np.zeros(n), HAU=np.zeros(n), eq=np.zeros(n),
        nu_b=np.zeros(nbil), nub_new=np.zeros(nbil), nub_try=np.zeros(nbil),
        gb=np.zeros(nbil), Gb=np.zeros((nbil, n)), gb_try=np.zeros(nbil),
        Gb_try=np.zeros((nbil, n)), gm=np.zeros(nbil), dgdt=np.zeros(nbil),
        r_c=np.zeros(nc), GN0=np.zeros((nc, n)), ys=np.zeros((1, n)), nuc_new=np.zeros(nc),
        nuc_try=np.zeros(nc),
        gap_try=np.zeros(nc), GN=np.zeros((nc, n)), GN_try=np.zeros((nc, n)),
        active=np.zeros(nc, dtype=np.bool_), Hloc=np.zeros((6, 6)), wN=np.zeros(6),
        wT=np.zeros(6), Gall=np.zeros((mt, n)), ball=np.zeros(mt), Y=np.zeros((mt, n)),
        AU=np.zeros(n),
        first=np.zeros(mt, dtype=np.int64), have=np.zeros(mt, dtype=np.bool_), x=np.zeros(n),
        Dall=np.zeros((mt, mt)), rows=np.zeros(mt, dtype=np.int64), Dbuf=np.zeros((mt, mt)),
        sol=np.zeros(mt), piv=np.zeros(mt, dtype=np.int64),
        cols=np.zeros((mt, 6), dtype=np.int64), ncols=np.zeros(mt, dtype=np.int64),
        AU_try=np.zeros(n), trig=trig_cache(n // 3) if trig is None else trig,
        P=np.zeros((2, 6)))


@step_kernel
def _position_rows(q_t, U, t1, ma, q1, gb, Gb, gm, dgdt, gap, GN, wN, wT, trig):
    """Joint and contact rows at q1 = q_t + U: joint residuals gb, Jacobian Gb, gaps and
    normal rows GN (only the six entries of each contact's bodies are written: the others are
    zero from the start and stay so). ``trig``: :func:`~.bodies.body_point_cached`."""
    ct_body = ma.ct_body
    for i in range(q_t.shape[0]):
        q1[i] = q_t[i] + U[i]
    bilateral_cached(q1, U, t1, ma, gb, Gb, gm, dgdt, trig)
    for k in range(gap.shape[0]):
        gap[k] = contact_rows_cached(q1, k, ma.ct_type, ma.ct_body, ma.ct_geom, wN, wT, trig)
        place_row(GN, k, wN, ct_body[k, 0], ct_body[k, 1])


@step_kernel
def _metric_product(Ap, fac, U, out):
    """out = Ap U, for an Ap that is diagonal but for the coupled block ``fac`` found when it
    was factorised (:func:`~.linalg.block_factor`)."""
    for i in range(U.shape[0]):
        out[i] = Ap[i, i] * U[i]
    idx = fac.idx
    kc = fac.info[0]
    for a in range(kc):
        i = idx[a]
        s = 0.0
        for b in range(kc):
            s += Ap[i, idx[b]] * U[idx[b]]
        out[i] = s


@step_kernel
def _contact_scale(k, r_c, facA, GN0, ys, cols, nbil, ncols):
    """The augmentation r_k = 1 / (G_k A^-1 G_k^T) of contact k, from its row at the predicted
    configuration (``GN0``), computed when first needed (``r_c[k]`` is 0 until then): only a
    contact that is loaded or penetrates, or becomes active, needs it."""
    if r_c[k] == 0.0:
        row0 = np.int64(0)  # (a literal 0 would compile a second specialisation)
        d = block_gram_entry(facA, GN0, k, ys, row0, cols, nbil + k, ncols[nbil + k])
        r_c[k] = 1.0 / d if d > 0.0 else 1.0
    return r_c[k]


@step_kernel
def _position_residual(U, nu_b, nu_c, r_c, mdiag, Ap, facA, gb, Gb, gap, GN, eq, cols,
                       ncols, GN0, ys, AU):
    """Scaled residual [m] of the position problem at (U, nu) from the rows at q_t + U
    (:func:`_position_rows`): joints, complementarity in the augmented-Lagrangian form
    (nu - max(0, nu - r g))/r, and equilibrium M^-1 (Ap U - G^T nu). ``facA``: the
    factorisation of Ap, whose coupled indices are the only ones with off-diagonal entries;
    ``cols``/``ncols``: the supports of the joint rows, then of the contact rows; ``GN0``,
    ``ys``: for :func:`_contact_scale`; ``AU`` receives Ap U (the Newton step needs it)."""
    n = U.shape[0]
    nbil = gb.shape[0]
    res = 0.0
    for r in range(nbil):
        res = max(res, abs(gb[r]))
    for k in range(gap.shape[0]):
        if nu_c[k] == 0.0 and gap[k] >= 0.0:
            continue  # an open contact without multiplier: its term is 0 whatever r_k
        rk = _contact_scale(k, r_c, facA, GN0, ys, cols, nbil, ncols)
        val = nu_c[k] - max(0.0, nu_c[k] - rk * gap[k])
        res = max(res, abs(val) / rk)
    _metric_product(Ap, facA, U, AU)
    for i in range(n):
        eq[i] = AU[i]
    for r in range(nbil):
        if nu_b[r] != 0.0:
            for t in range(ncols[r]):
                i = cols[r, t]
                eq[i] -= Gb[r, i] * nu_b[r]
    for k in range(gap.shape[0]):
        if nu_c[k] != 0.0:
            for t in range(ncols[nbil + k]):
                i = cols[nbil + k, t]
                eq[i] -= GN[k, i] * nu_c[k]
    for i in range(n):
        res = max(res, abs(eq[i]) / mdiag[i])
    return res


@step_kernel
def position_step(q_t, t1, h, tol, max_iter, eta, ma, Ks_t, q1, nu_c, gap, wk):
    """Position correction: M U = G^T nu (with the springs' elastic stiffness h^2 Ks in the
    metric, symmetric positive semi-definite so that the metric stays positive definite),
    joints g(q_t + U) = 0 and 0 <= g_N ⊥ nu_N >= 0 for every contact.

    Semismooth Newton with Delassus-scaled augmentation r_j = 1/(G_j A^-1 G_j^T), a proximal
    term (eta/r)(nu - nu_k) on active rows for redundant (pinched) contacts, and a backtracking
    line search on the scaled residual. ``nu_c`` and ``wk.nu_b`` hold the previous step's
    multipliers on entry (zeros at a run's start; the Newton iteration starts from them) and
    this step's on exit. ``wk``: :func:`position_work`. Returns (iterations, converged)."""
    mdiag = ma.mdiag
    ct_type = ma.ct_type
    ct_body = ma.ct_body
    n = q_t.shape[0]
    nbil = wk.nu_b.shape[0]
    nc = ct_type.shape[0]
    Ap = wk.Ap
    U = wk.U
    nu_b = wk.nu_b
    gb = wk.gb
    Gb = wk.Gb
    GN = wk.GN
    r_c = wk.r_c
    # the support of every row (joints first, then contacts): products with rows visit it only
    cols = wk.cols
    ncols = wk.ncols
    joint_support(ma.jt_type, ma.jt_body, cols, ncols)
    for k in range(nc):
        ncols[nbil + k] = pair_support(ct_body[k, 0], ct_body[k, 1], cols, nbil + k)
    # Ap = M + h^2 Ks: Ks is zero outside the springs' body-pair blocks (smooth_forces), and so
    # is Ap but for its diagonal, from the start
    scale_pair_blocks(Ap, Ks_t, h * h, ma.sp_body)
    for i in range(n):
        Ap[i, i] = h * h * Ks_t[i, i] + mdiag[i]
        U[i] = 0.0
    block_factor(Ap, n, wk.facA, SYMMETRIC)
    # warm start from the previous step's multipliers (a loaded contact, a pinched ball,
    # carries about the same from one step to the next): its Newton matrix then has the
    # contacts' geometric stiffness from the first iteration, and its active set is right
    # from the start (1.62 -> 1.13 iterations a step on the paper's case). A value a failed
    # step may have left (not finite, or a negative contact multiplier) starts from zero.
    for r in range(nbil):
        if not np.isfinite(nu_b[r]):
            nu_b[r] = 0.0
    for k in range(nc):
        if not (nu_c[k] > 0.0 and np.isfinite(nu_c[k])):
            nu_c[k] = 0.0
    # the rows at the predicted configuration; the Delassus scaling r_k of a contact comes
    # from them, on first need (_contact_scale)
    _position_rows(q_t, U, t1, ma, q1, gb, Gb, wk.gm, wk.dgdt, gap, GN, wk.wN, wk.wT, wk.trig)
    GN0 = wk.GN0
    ys = wk.ys
    for k in range(nc):
        r_c[k] = 0.0
        for t in range(ncols[nbil + k]):
            i = cols[nbil + k, t]
            GN0[k, i] = GN[k, i]
    AU = wk.AU  # Ap U at the current iterate, from its residual
    AU_try = wk.AU_try
    res = _position_residual(U, nu_b, nu_c, r_c, mdiag, Ap, wk.facA, gb, Gb, gap, GN,
                             wk.eq, cols, ncols, GN0, ys, AU)
    target = tol * h
    iters = 0
    converged = res <= target
    active = wk.active
    U_new = wk.U_new
    U_try = wk.U_try
    q_try = wk.q_try
    HAU = wk.HAU
    nub_new = wk.nub_new
    nub_try = wk.nub_try
    nuc_new = wk.nuc_new
    nuc_try = wk.nuc_try
    gb_try = wk.gb_try
    Gb_try = wk.Gb_try
    gap_try = wk.gap_try
    GN_try = wk.GN_try
    Hloc = wk.Hloc
    Hm = wk.Hm
    eta_k = eta
    Gall = wk.Gall
    ball = wk.ball
    rows = wk.rows  # rows[:nbil] are the joints, always present
    for r in range(nbil):
        rows[r] = r
    mt = nbil + nc
    sol = wk.sol
    # at least one Newton step, so that every step restores the joints (a drift below tol*h
    # would otherwise accumulate up to that level): what is left is the quadratic remainder
    # of one Newton step, at most 5e-12 m on the paper's case (tol*h = 1e-9 m)
    while (not converged or iters == 0) and iters < max_iter:
        iters += 1
        for k in range(nc):
            # (an open contact without multiplier is inactive whatever r_k)
            active[k] = (nu_c[k] != 0.0 or gap[k] < 0.0) and (
                nu_c[k] - _contact_scale(k, r_c, wk.facA, GN0, ys, cols, nbil, ncols)
                * gap[k] > 0.0)
        # Newton matrix of the equilibrium: A - sum nu_j d2g_j (contact geometric stiffness)
        fac = wk.facA
        loaded = False
        for k in range(nc):
            if nu_c[k] > 0.0:
                loaded = True
        if loaded:
            copy_matrix(Hm, Ap, n, n)
            for k in range(nc):
                if nu_c[k] > 0.0:
                    contact_hessian_into(q1, k, ma, Hloc, wk.P)
                    for a in range(6):
                        ba = ct_body[k, 0] if a < 3 else ct_body[k, 1]
                        if ba < 0:
                            continue
                        for c in range(6):
                            bc = ct_body[k, 0] if c < 3 else ct_body[k, 1]
                            if bc < 0:
                                continue
                            Hm[3 * ba + a % 3, 3 * bc + c % 3] -= nu_c[k] * Hloc[a, c]
            block_factor(Hm, n, wk.facH, SYMMETRIC)
            fac = wk.facH
        # the linearised problem of this iterate, for all rows: joints first, then contacts;
        # row i of the new iterate reads (D nu)_i = b_i (+ proximal term on contacts)
        copy_vector(HAU, AU, n)
        block_solve(fac, n, HAU)
        # (Gall is zero outside the rows' supports from the start)
        for r in range(nbil):
            s = -gb[r]
            for t in range(ncols[r]):
                i = cols[r, t]
                Gall[r, i] = Gb[r, i]
                s += Gb[r, i] * HAU[i]
            ball[r] = s
        for k in range(nc):
            s = -gap[k]
            for t in range(ncols[nbil + k]):
                i = cols[nbil + k, t]
                Gall[nbil + k, i] = GN[k, i]
                s += GN[k, i] * HAU[i]
            ball[nbil + k] = s
        # exact active set of the linearised problem (primal-dual active set): drop contacts
        # whose multiplier turns negative, add those whose linearised gap turns negative;
        # one geometric Newton step then never cycles on a degenerate contact. Only the
        # Delassus entries among the joints and active contacts are formed, each once per
        # Newton iteration (block_gram_rows adds a newly active row); an inactive contact's
        # linearised gap is G_k x with x = H^-1 G_active^T nu.
        have = wk.have
        Dall = wk.Dall
        for r in range(mt):
            have[r] = False
        x = wk.x
        m = nbil
        for _inner in range(8 * nc * nc + 8):
            m = nbil
            for k in range(nc):
                if active[k]:
                    rows[m] = nbil + k
                    m += 1
            block_gram_rows(fac, Gall, rows, m, wk.Y, wk.first, have, Dall, cols, ncols)
            D = wk.Dbuf  # its leading m x m block
            for a in range(m):
                ra = rows[a]
                for c in range(m):
                    D[a, c] = Dall[ra, rows[c]]
                sol[a] = ball[ra]
                if ra >= nbil:
                    # proximal term on the contacts, (eta / r_k)(nu - nu_k)
                    k = ra - nbil
                    reg = eta_k / _contact_scale(k, r_c, wk.facA, GN0, ys, cols, nbil, ncols)
                    D[a, a] += reg
                    sol[a] += reg * nu_c[k]
            lu_factor(D, m, wk.piv)
            lu_solve(D, m, wk.piv, sol)
            for i in range(n):
                x[i] = 0.0
            for a in range(m):
                ra = rows[a]
                for t in range(ncols[ra]):
                    i = cols[ra, t]
                    x[i] += Gall[ra, i] * sol[a]
            block_solve(fac, n, x)
            # Murty's least-index rule: flip only the first contact that violates the
            # complementarity; finite for the positive definite (P-matrix) contact problem,
            # where flipping every violator at once can cycle among redundant contacts
            flip = -1
            for a in range(nbil, m):
                if sol[a] < 0.0:
                    flip = rows[a] - nbil
                    break
            for k in range(nc):
                if flip >= 0 and k >= flip:
                    break
                if not active[k]:
                    # G_k x over the row's support (written out: a call of support_dot costs
                    # more than its six products)
                    s = 0.0
                    for t in range(ncols[nbil + k]):
                        i = cols[nbil + k, t]
                        s += Gall[nbil + k, i] * x[i]
                    lin_gap = -ball[nbil + k] + s
                    if lin_gap < -0.1 * target:
                        flip = k
                        break
            if flip < 0:
                break
            active[flip] = not active[flip]
        # U_new = U + H^-1 (Gall_active^T sol - Ap U)
        for i in range(n):
            U_new[i] = U[i] - HAU[i] + x[i]
        for r in range(nbil):
            nub_new[r] = sol[r]
        nuc_new[:] = 0.0
        for a in range(nbil, m):
            nuc_new[rows[a] - nbil] = sol[a]
        # backtracking line search on the scaled residual
        theta = 1.0
        best = -1.0
        best_theta = 1.0
        best_res = 0.0
        for _ls in range(12):
            for i in range(n):
                U_try[i] = U[i] + theta * (U_new[i] - U[i])
            for r in range(nbil):
                nub_try[r] = nu_b[r] + theta * (nub_new[r] - nu_b[r])
            for k in range(nc):
                nuc_try[k] = nu_c[k] + theta * (nuc_new[k] - nu_c[k])
            _position_rows(q_t, U_try, t1, ma, q_try, gb_try, Gb_try, wk.gm, wk.dgdt,
                           gap_try, GN_try, wk.wN, wk.wT, wk.trig)
            res_try = _position_residual(U_try, nub_try, nuc_try, r_c, mdiag, Ap, wk.facA,
                                         gb_try, Gb_try, gap_try, GN_try, wk.eq, cols, ncols,
                                         GN0, ys, AU_try)
            if best < 0.0 or res_try < best:
                best = res_try
                best_theta = theta
                best_res = res_try
            if res_try <= (1.0 - 1e-4 * theta) * res:
                break
            theta *= 0.5
        last_theta = theta
        theta = best_theta
        if theta < 0.125:
            # the active set cycles (the full step does not reduce the residual): stiffen the
            # proximal term so that the multipliers move less per iteration
            eta_k = min(100.0 * eta_k, 1e-1)
        elif theta == 1.0:
            eta_k = max(eta, 0.01 * eta_k)  # back towards plain Newton once steps go through
        if theta == last_theta:
            # the last trial is the new iterate: take its rows and residual as they are
            copy_vector(U, U_try, n)
            copy_vector(nu_b, nub_try, nbil)
            copy_vector(nu_c, nuc_try, nc)
            copy_vector(q1, q_try, n)
            copy_vector(gb, gb_try, nbil)
            copy_matrix(Gb, Gb_try, nbil, n)
            copy_vector(gap, gap_try, nc)
            copy_matrix(GN, GN_try, nc, n)
            copy_vector(AU, AU_try, n)
            res = best_res
        else:
            for i in range(n):
                U[i] += theta * (U_new[i] - U[i])
            for r in range(nbil):
                nu_b[r] += theta * (nub_new[r] - nu_b[r])
            for k in range(nc):
                nu_c[k] += theta * (nuc_new[k] - nu_c[k])
            _position_rows(q_t, U, t1, ma, q1, gb, Gb, wk.gm, wk.dgdt, gap, GN, wk.wN, wk.wT,
                           wk.trig)
            res = _position_residual(U, nu_b, nu_c, r_c, mdiag, Ap, wk.facA, gb, Gb, gap, GN,
                                     wk.eq, cols, ncols, GN0, ys, AU)
        converged = res <= target
    return iters, converged


def velocity_work(n, nbil, nc, trig=None):
    """Work arrays of :func:`velocity_step` (made once per run, in Python); ``trig``: see
    :func:`position_work`."""
    mv = nbil + 2 * nc
    return VelocityWork(
        f1=np.zeros(n), C1=np.zeros((n, n)),
        Av=np.zeros((n, n)), fac=block_factor_work(n), b=np.zeros(n), Ab=np.zeros(n),
        tmp=np.zeros(n), wN=np.zeros(6), wT=np.zeros(6),
        gb=np.zeros(nbil), gm=np.zeros(nbil), dgdt=np.zeros(nbil), Gb=np.zeros((nbil, n)),
        closed=np.zeros(nc, dtype=np.bool_), row_of=np.zeros(nc, dtype=np.int64),
        G=np.zeros((mv, n)), off=np.zeros(mv), kind=np.zeros(mv, dtype=np.int64),
        mu_row=np.zeros(mv), pair=np.zeros(mv, dtype=np.int64), lam=np.zeros(mv),
        Y=np.zeros((mv, n)), first=np.zeros(mv, dtype=np.int64), D=np.zeros((mv, mv)),
        c=np.zeros(mv),
        Dbb=np.zeros((nbil, nbil)), pivb=np.zeros(nbil, dtype=np.int64), colb=np.zeros(nbil),
        X=np.zeros((nbil, mv + 1)), Dc=np.zeros((mv, mv)), cc=np.zeros(mv),
        lam_c=np.zeros(mv), pair_c=np.zeros(mv, dtype=np.int64),
        cols=np.zeros((mv, 6), dtype=np.int64), ncols=np.zeros(mv, dtype=np.int64),
        solver=velocity_solver_work(mv), trig=trig_cache(n // 3) if trig is None else trig,
        fw=np.zeros((3, 6)), iw=np.zeros((2, 6), dtype=np.int64))


def velocity_solver_work(m):
    """Work arrays of the semismooth Newton solver of the velocity problem (m rows at most)."""
    return VelocitySolverWork(r=np.zeros(m), F=np.zeros(m), F_try=np.zeros(m), xi=np.zeros(m),
                              xi_try=np.zeros(m), lam_try=np.zeros(m), dl=np.zeros(m),
                              J=np.zeros((m, m)), piv=np.zeros(m, dtype=np.int64),
                              branch=np.zeros(m, dtype=np.int64))


@step_kernel
def _affine(D, lam, c, m, xi):
    """xi = D lam + c on the leading m rows."""
    for i in range(m):
        s = c[i]
        for j in range(m):
            s += D[i, j] * lam[j]
        xi[i] = s


@step_kernel
def _velocity_residual(lam, xi, kind, r, mu_row, pair, F):
    """Scaled residual [m/s] of the velocity problem, row by row.

    kind: 0 bilateral, 1 normal, 2 tangential (pair = index of its normal row)."""
    res = 0.0
    for i in range(lam.shape[0]):
        if kind[i] == 0:
            F[i] = xi[i]
        elif kind[i] == 1:
            F[i] = (lam[i] - max(0.0, lam[i] - r[i] * xi[i])) / r[i]
        else:
            bound = mu_row[i] * max(lam[pair[i]], 0.0)
            z = lam[i] - r[i] * xi[i]
            proj = min(max(z, -bound), bound)
            F[i] = (lam[i] - proj) / r[i]
        res = max(res, abs(F[i]))
    return res


@step_kernel
def _local_frictional_contact(D, c, lam, i, mu):
    """Solve one contact's rows (normal i, tangent i+1) exactly, the others held fixed."""
    j = i + 1
    bN = c[i]
    bT = c[j]
    for p in range(lam.shape[0]):
        if p != i and p != j:
            bN += D[i, p] * lam[p]
            bT += D[j, p] * lam[p]
    wNN = D[i, i]
    wNT = D[i, j]
    wTN = D[j, i]
    wTT = D[j, j]
    if bN >= 0.0:
        lam[i] = 0.0
        lam[j] = 0.0
        return
    det = wNN * wTT - wNT * wTN
    if det > 0.0:
        ln = (-bN * wTT + bT * wNT) / det
        lt = (-bT * wNN + bN * wTN) / det
        if ln >= 0.0 and abs(lt) <= mu * ln:
            lam[i] = ln
            lam[j] = lt
            return
    for sigma in (1.0, -1.0):
        den = wNN - sigma * mu * wNT
        if den <= 0.0:
            continue
        ln = -bN / den
        xt = (wTN - sigma * mu * wTT) * ln + bT
        if ln >= 0.0 and sigma * xt >= 0.0:
            lam[i] = ln
            lam[j] = -sigma * mu * ln
            return
    # no consistent case (degenerate block): projected update
    lam[i] = max(0.0, -bN / wNN) if wNN > 0.0 else 0.0
    bound = mu * lam[i]
    lam[j] = min(max(-(bT + wTN * lam[i]) / wTT if wTT > 0.0 else 0.0, -bound), bound)


def nonsmooth_work(n, nbil, nc):
    """Every work array of :func:`integrate_chunk` for n coordinates, nbil joint rows and nc
    contacts, made once per run (the position correction and the velocity jump share one
    sine/cosine cache: the jump's rows are at the position correction's last configuration)."""
    trig = trig_cache(n // 3)
    return NonsmoothWork(step=step_work(n), smooth=smooth_work(n, nbil),
                         position=position_work(n, nbil, nc, trig),
                         velocity=velocity_work(n, nbil, nc, trig),
                         contact=(np.zeros(nc), np.zeros(nc), np.zeros(nc), np.zeros(nc),
                                  np.zeros(nc)))


def solve_velocity_problem(D, c, kind, mu_row, pair, lam, tol, max_iter, eta):
    """Solve xi = D lam + c with xi_b = 0 (joints), Newton's law 0 <= xi_N ⊥ lam_N >= 0 and
    Coulomb's law |lam_T| <= mu lam_N (stick xi_T = 0, else lam_T opposes xi_T).

    Semismooth Newton with Delassus-scaled augmentation, proximal regularisation and a line
    search; projected Gauss-Seidel as fallback. ``lam`` holds the warm start on entry and the
    solution on exit. Returns (iterations, converged). (Allocates its work arrays; the time
    loop calls :func:`_solve_velocity_problem` with arrays made once per run.)"""
    return _solve_velocity_problem(D, c, kind, mu_row, pair, lam, tol, max_iter, eta,
                                   velocity_solver_work(lam.shape[0]))


@step_kernel
def _solve_velocity_problem(D, c, kind, mu_row, pair, lam, tol, max_iter, eta, sw):
    """:func:`solve_velocity_problem` on the work arrays ``sw`` (:func:`velocity_solver_work`)."""
    m = lam.shape[0]
    r = sw.r[:m]
    F = sw.F[:m]
    F_try = sw.F_try[:m]
    xi = sw.xi[:m]
    xi_try = sw.xi_try[:m]
    lam_try = sw.lam_try[:m]
    dl = sw.dl[:m]
    J = sw.J  # its leading m x m block
    for i in range(m):
        r[i] = 1.0
        if D[i, i] > 0.0:
            r[i] = 1.0 / D[i, i]
    _affine(D, lam, c, m, xi)
    res = _velocity_residual(lam, xi, kind, r, mu_row, pair, F)
    iters = 0
    # at least one Newton step: the problem is piecewise linear, so one step on the right
    # active set is exact, while a warm start that merely meets the tolerance leaves velocity
    # errors of order tol that show up as force chatter in persistent contact (tol m / h)
    # iterate to half the tolerance: the admissibility projection at exit may move the
    # residual by a comparable amount
    branch = sw.branch
    while (res > 0.5 * tol or iters == 0) and iters < max_iter and m > 0:
        iters += 1
        # the branch of each row's law at this iterate: 0 a row of D (joint, closed contact,
        # sticking), 1 an open contact, 2 a slip without a normal impulse, 3/4 a slip in the
        # positive/negative direction. The Newton matrix depends on D, r, eta and these alone:
        # where no row changed branch since the last iteration, its factors are reused.
        same = iters > 1
        for i in range(m):
            if kind[i] == 0:
                b = 0
            elif kind[i] == 1:
                b = 0 if lam[i] - r[i] * xi[i] > 0.0 else 1
            else:
                bound = mu_row[i] * max(lam[pair[i]], 0.0)
                z = lam[i] - r[i] * xi[i]
                if abs(z) < bound:
                    b = 0
                elif lam[pair[i]] > 0.0:
                    b = 3 if z > 0.0 else 4
                else:
                    b = 2
            same = same and branch[i] == b
            branch[i] = b
        if not same:
            for i in range(m):
                for j in range(m):
                    J[i, j] = 0.0
            for i in range(m):
                b = branch[i]
                if b == 0:
                    copy_vector(J[i], D[i], m)
                    if kind[i] != 0:
                        J[i, i] += eta * D[i, i]
                else:
                    J[i, i] = 1.0 / r[i]
                    if b >= 3:
                        s = 1.0 if b == 3 else -1.0
                        J[i, pair[i]] = -mu_row[i] * s / r[i]
            lu_factor(J, m, sw.piv)
        for i in range(m):
            dl[i] = -F[i]
        lu_solve(J, m, sw.piv, dl)
        # backtracking on the squared 2-norm of the residual (the max-norm stalls)
        merit = 0.0
        for i in range(m):
            merit += F[i] * F[i]
        theta = 1.0
        best = -1.0
        best_theta = 1.0
        for _ls in range(12):
            for i in range(m):
                lam_try[i] = lam[i] + theta * dl[i]
            _affine(D, lam_try, c, m, xi_try)
            _velocity_residual(lam_try, xi_try, kind, r, mu_row, pair, F_try)
            merit_try = 0.0
            for i in range(m):
                merit_try += F_try[i] * F_try[i]
            if best < 0.0 or merit_try < best:
                best = merit_try
                best_theta = theta
            if merit_try <= (1.0 - 1e-4 * theta) * merit:
                break
            theta *= 0.5
        for i in range(m):
            lam[i] += best_theta * dl[i]
        if best_theta == theta:
            # the last trial is the new iterate: reuse its velocities and residual
            copy_vector(xi, xi_try, m)
            copy_vector(F, F_try, m)
            res = 0.0
            for i in range(m):
                res = max(res, abs(F[i]))
        else:
            _affine(D, lam, c, m, xi)
            res = _velocity_residual(lam, xi, kind, r, mu_row, pair, F)
    if res > 0.5 * tol:
        # fallback: nonsmooth block Gauss-Seidel (each contact's normal/tangent pair solved
        # exactly by enumerating open, stick and the two slip directions), slow but robust
        # where redundant frictional contacts make the Newton iteration stall
        for _sweep in range(200 * max_iter):
            iters += 1
            i = np.int64(0)  # not a literal 0, which compiles a second specialisation
            while i < m:
                if kind[i] == 1 and i + 1 < m and kind[i + 1] == 2 and pair[i + 1] == i:
                    _local_frictional_contact(D, c, lam, i, mu_row[i + 1])
                    i += 2
                    continue
                xi_i = c[i]
                for j in range(m):
                    xi_i += D[i, j] * lam[j]
                if kind[i] == 0:
                    lam[i] = lam[i] - r[i] * xi_i
                elif kind[i] == 1:
                    lam[i] = max(0.0, lam[i] - r[i] * xi_i)
                else:
                    bound = mu_row[i] * max(lam[pair[i]], 0.0)
                    lam[i] = min(max(lam[i] - r[i] * xi_i, -bound), bound)
                i += 1
            _affine(D, lam, c, m, xi)
            res = _velocity_residual(lam, xi, kind, r, mu_row, pair, F)
            if res <= 0.5 * tol:
                break
    # the law holds to the tolerance; make the impulses admissible exactly (Lambda_N >= 0,
    # |Lambda_T| <= mu Lambda_N), which moves the velocities by less than tol
    moved = False
    for i in range(m):
        if kind[i] == 1 and lam[i] < 0.0:
            lam[i] = 0.0
            moved = True
    for i in range(m):
        if kind[i] == 2:
            bound = mu_row[i] * lam[pair[i]]
            clipped = min(max(lam[i], -bound), bound)
            if clipped != lam[i]:
                lam[i] = clipped
                moved = True
    if moved:
        # (otherwise xi and the residual are those of these impulses already)
        _affine(D, lam, c, m, xi)
        res = _velocity_residual(lam, xi, kind, r, mu_row, pair, F)
    return iters, res <= tol


@step_kernel
def velocity_step(q1, q_t, v_t, t1, h, tol, max_iter, eta, gap_close, ma, f_t, nu_c, gap,
                  vn_minus, vt_minus, v1, lamN, lamT, lam_b, wk):
    """Velocity jump W = v1 - v_t with impulses Lambda on the joints and on the contacts closed
    after the position correction (nu_N > 0 or g_N <= gap_close). ``lamN``/``lamT`` hold the
    previous step's impulses (warm start) on entry. ``wk``: :func:`velocity_work`. Returns
    (iterations, converged)."""
    mdiag = ma.mdiag
    ct_type = ma.ct_type
    ct_body = ma.ct_body
    ct_law = ma.ct_law
    n = q1.shape[0]
    nbil = wk.gb.shape[0]
    nc = ct_type.shape[0]
    f1 = wk.f1
    C1 = wk.C1
    # the forces at (q1, v~) and the damping matrix (the stiffness is not needed here)
    smooth_forces_into(q1, v_t, ma, f1, C1, C1, C1, FORCES_ONLY, wk.fw, wk.iw)
    spring_damping_into(q1, v_t, ma, C1, wk.fw, wk.iw)
    Av = wk.Av
    b = wk.b
    # Av = M + h C, on the springs' blocks and the diagonal (see position_step)
    scale_pair_blocks(Av, C1, h, ma.sp_body)
    for i in range(n):
        Av[i, i] = h * C1[i, i] + mdiag[i]
        b[i] = h * (f1[i] - f_t[i])
    fac = wk.fac
    block_factor(Av, n, fac, SYMMETRIC)
    Ab = wk.Ab
    copy_vector(Ab, b, n)
    block_solve(fac, n, Ab)
    Gb = wk.Gb
    dgdt = wk.dgdt
    bilateral_cached(q1, v_t, t1, ma, wk.gb, Gb, wk.gm, dgdt, wk.trig)
    closed = wk.closed
    n_rows = nbil
    for k in range(nc):
        closed[k] = nu_c[k] > 0.0 or gap[k] <= gap_close
        if closed[k]:
            n_rows += 2 if ct_law[k, 0] > 0.0 else 1
    G = wk.G
    off = wk.off
    kind = wk.kind
    mu_row = wk.mu_row
    pair = wk.pair
    lam = wk.lam
    row_of = wk.row_of
    row_of[:] = -1
    cols = wk.cols
    ncols = wk.ncols
    joint_support(ma.jt_type, ma.jt_body, cols, ncols)
    for r in range(nbil):
        for i in range(n):
            G[r, i] = Gb[r, i]
        off[r] = dgdt[r]
        kind[r] = 0
        mu_row[r] = 0.0
        pair[r] = 0
        lam[r] = lam_b[r] if lam_b.shape[0] == nbil else 0.0
    wN = wk.wN
    wT = wk.wT
    row = nbil
    for k in range(nc):
        lamN_prev = lamN[k]
        lamT_prev = lamT[k]
        lamN[k] = 0.0
        lamT[k] = 0.0
        if not closed[k]:
            continue
        contact_rows_cached(q1, k, ma.ct_type, ma.ct_body, ma.ct_geom, wN, wT, wk.trig)
        scatter_row(G[row], wN, ct_body[k, 0], ct_body[k, 1])
        ncols[row] = pair_support(ct_body[k, 0], ct_body[k, 1], cols, row)
        # Newton's law as docs/model.md states it, with the start-of-step velocity also where
        # the contact was separating then (closed by the position correction, e.g. the partner
        # of a pinched ball): xi_N = dg_N+ + e_N dg_N- may then leave it slightly approaching.
        # Clipping dg_N- at 0 there was tried: with several simultaneous Newton laws around a
        # pinched ball it fed energy into the paper's case (a blow-up within 20 ms).
        off[row] = ct_law[k, 1] * vn_minus[k]
        kind[row] = 1
        mu_row[row] = 0.0
        pair[row] = 0
        lam[row] = lamN_prev
        row_of[k] = row
        row += 1
        if ct_law[k, 0] > 0.0:
            scatter_row(G[row], wT, ct_body[k, 0], ct_body[k, 1])
            ncols[row] = pair_support(ct_body[k, 0], ct_body[k, 1], cols, row)
            off[row] = ct_law[k, 2] * vt_minus[k]
            kind[row] = 2
            mu_row[row] = ct_law[k, 0]
            pair[row] = row - 1
            lam[row] = lamT_prev
            row += 1
    # Delassus matrix D = G A^-1 G^T and free velocity c = G (v_t + A^-1 b) + off
    D = wk.D
    c = wk.c
    block_gram(fac, G, n_rows, wk.Y, wk.first, D, cols, ncols)
    for a in range(n_rows):
        s = off[a]
        for t in range(ncols[a]):
            i = cols[a, t]
            s += G[a, i] * (v_t[i] + Ab[i])
        c[a] = s
    sw = wk.solver
    if nbil > 0 and n_rows > nbil:
        # eliminate the joints (equalities) first: the contact problem then sees the
        # mechanism's effective masses, and its Gauss-Seidel fallback converges
        nct = n_rows - nbil
        Dbb = wk.Dbb
        for a in range(nbil):
            for c2 in range(nbil):
                Dbb[a, c2] = D[a, c2]
        lu_factor(Dbb, nbil, wk.pivb)
        # X = Dbb^-1 [Dbc, c_b], one column at a time
        X = wk.X  # its leading nbil x (nct + 1) block
        col = wk.colb
        for j in range(nct + 1):
            for a in range(nbil):
                col[a] = D[a, nbil + j] if j < nct else c[a]
            lu_solve(Dbb, nbil, wk.pivb, col)
            for a in range(nbil):
                X[a, j] = col[a]
        Dc = wk.Dc  # its leading nct x nct block
        cc = wk.cc[:nct]
        lam_c = wk.lam_c[:nct]
        pair_c = wk.pair_c[:nct]
        for a in range(nct):
            for j in range(nct):
                s = D[nbil + a, nbil + j]
                for p in range(nbil):
                    s -= D[nbil + a, p] * X[p, j]
                Dc[a, j] = s
            s = c[nbil + a]
            for p in range(nbil):
                s -= D[nbil + a, p] * X[p, nct]
            cc[a] = s
            lam_c[a] = lam[nbil + a]
            pair_c[a] = pair[nbil + a] - nbil
        iters, ok = _solve_velocity_problem(Dc, cc, kind[nbil:n_rows], mu_row[nbil:n_rows],
                                            pair_c, lam_c, tol, max_iter, eta, sw)
        for a in range(nct):
            lam[nbil + a] = lam_c[a]
        for p in range(nbil):
            s = X[p, nct]
            for j in range(nct):
                s += X[p, j] * lam_c[j]
            lam[p] = -s
        # check the joints too (round-off only)
        for r in range(nbil):
            xi_b = c[r]
            for j in range(n_rows):
                xi_b += D[r, j] * lam[j]
            if abs(xi_b) > tol:
                ok = False
    else:
        Dv = wk.Dc  # its leading n_rows x n_rows block
        for a in range(n_rows):
            for j in range(n_rows):
                Dv[a, j] = D[a, j]
        iters, ok = _solve_velocity_problem(Dv, c[:n_rows], kind[:n_rows], mu_row[:n_rows],
                                            pair[:n_rows], lam[:n_rows], tol, max_iter, eta,
                                            sw)
    # W = A^-1 (b + G^T Lambda)
    W = wk.tmp
    for i in range(n):
        W[i] = b[i]
    for r in range(n_rows):
        for t in range(ncols[r]):
            i = cols[r, t]
            W[i] += G[r, i] * lam[r]
    block_solve(fac, n, W)
    for i in range(n):
        v1[i] = v_t[i] + W[i]
    for r in range(nbil):
        lam_b[r] = lam[r]
    for k in range(nc):
        rk = row_of[k]
        if rk >= 0:
            lamN[k] = lam[rk]
            if ct_law[k, 0] > 0.0:
                lamT[k] = lam[rk + 1]
    return iters, ok


def loop_stage_calls(st, ma, state, work):
    """The calls :func:`integrate_chunk` makes to its three stages, as (kernel, arguments) by
    stage name ("smooth", "position", "velocity"): the loop's own objects, so that each stage
    can be compiled for the loop's argument types ahead of the loop
    (:mod:`simcore.startup.parallel_compile`). Plain Python; keep it in step with the loop's calls
    (``tests/test_parallel_compile.py`` checks that the types are the loop's)."""
    q_t, v_t, acc1, vdot1, f_t, K_t, C_t, Ks_t, q1, v1 = work.step
    nu_c, gap = work.contact[0], work.contact[1]
    h, tol, max_iter, eta = st.h, st.tol, st.max_iter, st.eta
    t1 = st.t0 + h
    coef = alpha_coefficients.py_func(st.rho_inf)  # (the Python function: nothing compiled)
    return {
        "smooth": (smooth_step, (state.q, state.v, state.acc, state.vdot, state.lam_s, t1, h,
                                 coef, st, ma, work.step, work.smooth)),
        "position": (position_step, (q_t, t1, h, tol, max_iter, eta, ma, Ks_t, q1, nu_c, gap,
                                     work.position)),
        "velocity": (velocity_step, (q1, q_t, v_t, t1, h, tol, max_iter, eta, tol * h, ma, f_t,
                                     nu_c, gap, state.vn, state.vt, v1, state.lamN, state.lamT,
                                     state.lam_b, work.velocity)),
    }


@loop_kernel
def integrate_chunk(k0, k1, st, ma, state, out, work):
    """Advance steps k0 .. k1-1 (state at time k0*h on entry, at k1*h on exit), writing the
    outputs of each step at index k+1.

    Parameters
    ----------
    st : StepSettings
        h [s], rho_inf, tol, max_iter, eta, drive_row.
    ma : ModelArrays
        The model.
    state : StepState
        Updated in place.
    work : NonsmoothWork
        Work arrays (:func:`nonsmooth_work`), reused from chunk to chunk.
    out : ChunkOutputs
        ``out.vn_free`` receives the normal relative velocity just before the jump of the step,
        G_N(q_{n+1}) v~_{n+1}: the smooth-step velocity seen by the contact rows at the
        corrected position [m/s].

    Returns
    -------
    int
        The index of the first step whose sub-problems did not all converge, or -1.
    """
    h = st.h
    tol = st.tol
    max_iter = st.max_iter
    eta = st.eta
    drive_row = st.drive_row
    q = state.q
    v = state.v
    acc = state.acc
    vdot = state.vdot
    lam_s = state.lam_s
    lam_b = state.lam_b
    lamN_prev = state.lamN
    lamT_prev = state.lamT
    vn_prev = state.vn
    vt_prev = state.vt
    n = q.shape[0]
    nc = ma.ct_type.shape[0]
    nbil = work.position.nu_b.shape[0]
    coef = alpha_coefficients(st.rho_inf)
    q_t, v_t, acc1, vdot1, f_t, K_t, C_t, Ks_t, q1, v1 = work.step
    nu_c, gap, vn, vt, vn_free = work.contact
    pwk = work.position
    vwk = work.velocity
    gap_close = tol * h
    sw = work.smooth
    first_bad = -1
    for k in range(k0, k1):
        t1 = (k + 1) * h
        it_s, ok_s = smooth_step(q, v, acc, vdot, lam_s, t1, h, coef, st, ma, work.step, sw)
        it_p, ok_p = position_step(q_t, t1, h, tol, max_iter, eta, ma, Ks_t, q1, nu_c, gap,
                                   pwk)
        # normal velocities before the jump, G_N(q1) v~, from the position stage's rows at q1
        # (written out: a call of support_dot costs more than its six products)
        GN = pwk.GN
        pcols = pwk.cols
        pncols = pwk.ncols
        for j in range(nc):
            s = 0.0
            for t in range(pncols[nbil + j]):
                i = pcols[nbil + j, t]
                s += GN[j, i] * v_t[i]
            vn_free[j] = s
        it_v, ok_v = velocity_step(q1, q_t, v_t, t1, h, tol, max_iter, eta, gap_close, ma, f_t,
                                   nu_c, gap, vn_prev, vt_prev, v1, lamN_prev, lamT_prev, lam_b,
                                   vwk)
        # accept the step
        for i in range(n):
            q[i] = q1[i]
            v[i] = v1[i]
            acc[i] = acc1[i]
            vdot[i] = vdot1[i]
        contact_velocities_into(q, v, ma, gap, vn, vt, pwk.wN, pwk.wT, pwk.trig)
        copy_vector(out.q[k + 1], q, n)
        copy_vector(out.v[k + 1], v, n)
        for j in range(nc):
            out.lambda_N[k + 1, j] = lamN_prev[j]
            out.lambda_T[k + 1, j] = lamT_prev[j]
            out.nu_N[k + 1, j] = nu_c[j]
            out.gap_N[k + 1, j] = gap[j]
            out.vn_pre[k + 1, j] = vn_prev[j]
            out.vn_post[k + 1, j] = vn[j]
            out.vn_free[k + 1, j] = vn_free[j]
            vn_prev[j] = vn[j]
            vt_prev[j] = vt[j]
        out.energy[k + 1] = total_energy(q, v, ma)
        out.iterations[k + 1, STAGE_SMOOTH] = it_s
        out.iterations[k + 1, STAGE_POSITION] = it_p
        out.iterations[k + 1, STAGE_VELOCITY] = it_v
        ok = ok_s and ok_p and ok_v
        out.converged[k + 1] = 1 if ok else 0
        if drive_row >= 0:
            out.drive_torque[k + 1] = lam_s[drive_row] + lam_b[drive_row] / h
        if not ok and first_bad < 0:
            first_bad = k
    return first_bad
