"""The velocity jump of the nonsmooth step: impulses on the joints and on the contacts closed
after the position correction, with Newton's impact law and Coulomb friction.

:func:`velocity_step` reads as its stages: :func:`_jump_metric` (M + h C and the smooth
forces' change), :func:`_jump_rows` (the rows of the problem), :func:`_delassus` (D and the
free velocity), :func:`_solve_jump` (joints eliminated, then the frictional contact problem,
:func:`solve_velocity_problem`) and :func:`_apply_jump`. The contact problem's solver reads
likewise: semismooth Newton (:func:`_law_branches`, :func:`_factor_velocity_newton`,
:func:`_velocity_line_search`), a Gauss-Seidel fallback (:func:`_gauss_seidel`), in a
retried step Newton again from the fallback's iterate (:func:`_newton_after_fallback`), and
the admissibility projection (:func:`_make_admissible`).
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from .bodies import pair_support, scale_pair_blocks, scatter_row, trig_cache
from .contact import contact_rows_cached
from .jit import stage, step_kernel
from .joints import bilateral_cached, joint_support
from .linalg import (
    SYMMETRIC,
    block_factor,
    block_factor_work,
    block_gram,
    block_solve,
    copy_vector,
    lu_factor,
    lu_solve,
)
from .springs import FORCES_ONLY, smooth_forces_into, spring_damping_into

#: Kinds of the velocity problem's rows (``kind``): a joint's, a contact's normal and its
#: tangential row (whose ``pair`` is the index of its normal row).
ROW_JOINT = 0
ROW_NORMAL = 1
ROW_TANGENT = 2

#: Branches of a row's law at a Newton iterate (``branch``): a row of D (a joint, a closed
#: contact, a sticking contact); an open contact; a slip without normal impulse (bound 0); a
#: slip at the bound in the positive / negative direction. The Newton matrix depends on D, r,
#: eta and these alone.
BRANCH_ROW = 0
BRANCH_OPEN = 1
BRANCH_FREE = 2
BRANCH_SLIP_POS = 3
BRANCH_SLIP_NEG = 4

#: Backtracking trials of the Newton line search (step halved each time).
LINE_SEARCH_TRIALS = 12
#: Gauss-Seidel sweeps of the fallback per allowed Newton iteration (solver.max_iter).
SWEEPS_PER_ITERATION = 200

#: The metric of the jump: the forces f1 and damping C1 at (q1, v~) (with the springs' work
#: rows ``fw``, ``iw``), Av = M + h C and its factor ``fac``, b = h (f1 - f~), Ab = Av^-1 b and
#: the jump W (``W``).
JumpMetric = namedtuple("JumpMetric", ["f1", "C1", "Av", "fac", "b", "Ab", "W", "fw", "iw"])

#: The rows of the velocity problem: the joints' (``gb``, ``Gb``, ``gm``, ``dgdt``), a
#: contact's (``wN``, ``wT``; sine/cosine cache ``trig``), the ``closed`` contacts and their
#: first row ``row_of``; the problem's rows ``G`` with their offsets ``off``, ``kind``,
#: friction coefficient ``mu_row``, normal row ``pair`` and impulses ``lam``, their supports
#: ``cols``/``ncols``.
JumpRows = namedtuple("JumpRows", ["gb", "Gb", "gm", "dgdt", "wN", "wT", "trig", "closed",
                                   "row_of", "G", "off", "kind", "mu_row", "pair", "lam",
                                   "cols", "ncols"])

#: The problem's Delassus matrix D = G Av^-1 G^T (formed with ``Y``, ``first``) and free
#: velocity ``c``; the joints' elimination (``Dbb``, ``pivb``, ``colb``, X = Dbb^-1 [Dbc, c_b])
#: and the contact problem that remains (``Dc``, ``cc``, ``lam_c``, ``pair_c``).
JumpProblem = namedtuple("JumpProblem", ["Y", "first", "D", "c", "Dbb", "pivb", "colb", "X",
                                         "Dc", "cc", "lam_c", "pair_c"])

#: Work arrays of the velocity jump (:func:`velocity_work`): its ``metric``
#: (:data:`JumpMetric`), ``rows`` (:data:`JumpRows`), ``problem`` (:data:`JumpProblem`) and
#: the contact solver's arrays ``solver`` (:data:`VelocitySolverWork`).
VelocityWork = namedtuple("VelocityWork", ["metric", "rows", "problem", "solver"])

#: Work arrays of the velocity problem's Newton solver: the augmentation r, the residual F and
#: a trial's F_try, velocities xi and xi_try, trial impulses lam_try, the Newton step dl, its
#: matrix J and pivots piv, the law's branch of each row, and the fallback's impulses kept
#: while Newton tries to finish them (lam_keep).
VelocitySolverWork = namedtuple("VelocitySolverWork", ["r", "F", "F_try", "xi", "xi_try",
    "lam_try", "dl", "J", "piv", "branch", "lam_keep"])

#: A contact problem xi = D lam + c (:func:`solve_velocity_problem`): its matrix and free
#: velocity, each row's kind, friction coefficient and normal row, the impulses.
VelocityProblem = namedtuple("VelocityProblem", ["D", "c", "kind", "mu_row", "pair", "lam"])


def velocity_work(n, nbil, nc, trig=None):
    """Work arrays of :func:`velocity_step` (made once per run, in Python); ``trig``: see
    :func:`~.position_correction.position_work`."""
    mv = nbil + 2 * nc
    metric = JumpMetric(f1=np.zeros(n), C1=np.zeros((n, n)), Av=np.zeros((n, n)),
                        fac=block_factor_work(n), b=np.zeros(n), Ab=np.zeros(n), W=np.zeros(n),
                        fw=np.zeros((3, 6)), iw=np.zeros((2, 6), dtype=np.int64))
    rows = JumpRows(
        gb=np.zeros(nbil), Gb=np.zeros((nbil, n)), gm=np.zeros(nbil), dgdt=np.zeros(nbil),
        wN=np.zeros(6), wT=np.zeros(6), trig=trig_cache(n // 3) if trig is None else trig,
        closed=np.zeros(nc, dtype=np.bool_), row_of=np.zeros(nc, dtype=np.int64),
        G=np.zeros((mv, n)), off=np.zeros(mv), kind=np.zeros(mv, dtype=np.int64),
        mu_row=np.zeros(mv), pair=np.zeros(mv, dtype=np.int64), lam=np.zeros(mv),
        cols=np.zeros((mv, 6), dtype=np.int64), ncols=np.zeros(mv, dtype=np.int64))
    problem = JumpProblem(
        Y=np.zeros((mv, n)), first=np.zeros(mv, dtype=np.int64), D=np.zeros((mv, mv)),
        c=np.zeros(mv), Dbb=np.zeros((nbil, nbil)), pivb=np.zeros(nbil, dtype=np.int64),
        colb=np.zeros(nbil), X=np.zeros((nbil, mv + 1)), Dc=np.zeros((mv, mv)),
        cc=np.zeros(mv), lam_c=np.zeros(mv), pair_c=np.zeros(mv, dtype=np.int64))
    return VelocityWork(metric=metric, rows=rows, problem=problem,
                        solver=velocity_solver_work(mv))


def velocity_solver_work(m):
    """Work arrays of the semismooth Newton solver of the velocity problem (m rows at most)."""
    return VelocitySolverWork(r=np.zeros(m), F=np.zeros(m), F_try=np.zeros(m), xi=np.zeros(m),
                              xi_try=np.zeros(m), lam_try=np.zeros(m), dl=np.zeros(m),
                              J=np.zeros((m, m)), piv=np.zeros(m, dtype=np.int64),
                              branch=np.zeros(m, dtype=np.int64), lam_keep=np.zeros(m))


# -- the contact problem ---------------------------------------------------------------------

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
    """Scaled residual [m/s] of the velocity problem, row by row (``kind``: :data:`ROW_JOINT`,
    :data:`ROW_NORMAL`, :data:`ROW_TANGENT`)."""
    res = 0.0
    for i in range(lam.shape[0]):
        if kind[i] == ROW_JOINT:
            F[i] = xi[i]
        elif kind[i] == ROW_NORMAL:
            F[i] = (lam[i] - max(0.0, lam[i] - r[i] * xi[i])) / r[i]
        else:
            bound = mu_row[i] * max(lam[pair[i]], 0.0)
            z = lam[i] - r[i] * xi[i]
            proj = min(max(z, -bound), bound)
            F[i] = (lam[i] - proj) / r[i]
        res = max(res, abs(F[i]))
    return res


@step_kernel
def _residual(p, lam, r, xi, F):
    """xi = D lam + c and the residual F of the problem ``p`` at ``lam`` (augmentation ``r``);
    returns its max-norm."""
    _affine(p.D, lam, p.c, lam.shape[0], xi)
    return _velocity_residual(lam, xi, p.kind, r, p.mu_row, p.pair, F)


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


@stage
def _law_branches(p, first, w):
    """The branch of each row's law at the iterate (``w.branch``, see :data:`BRANCH_ROW`);
    returns True when none changed since the last iteration (never on the ``first``)."""
    lam = p.lam
    kind = p.kind
    r = w.r
    xi = w.xi
    branch = w.branch
    same = not first
    for i in range(lam.shape[0]):
        if kind[i] == ROW_JOINT:
            b = BRANCH_ROW
        elif kind[i] == ROW_NORMAL:
            b = BRANCH_ROW if lam[i] - r[i] * xi[i] > 0.0 else BRANCH_OPEN
        else:
            bound = p.mu_row[i] * max(lam[p.pair[i]], 0.0)
            z = lam[i] - r[i] * xi[i]
            if abs(z) < bound:
                b = BRANCH_ROW
            elif lam[p.pair[i]] > 0.0:
                b = BRANCH_SLIP_POS if z > 0.0 else BRANCH_SLIP_NEG
            else:
                b = BRANCH_FREE
        same = same and branch[i] == b
        branch[i] = b
    return same


@stage
def _factor_velocity_newton(p, eta, w):
    """Form and LU-factorise the semismooth Newton matrix of the branches ``w.branch``: a row
    of D (plus the proximal term eta D_ii on contact rows) on :data:`BRANCH_ROW`, the law's
    own row otherwise."""
    m = p.lam.shape[0]
    J = w.J
    r = w.r
    for i in range(m):
        for j in range(m):
            J[i, j] = 0.0
    for i in range(m):
        b = w.branch[i]
        if b == BRANCH_ROW:
            copy_vector(J[i], p.D[i], m)
            if p.kind[i] != ROW_JOINT:
                J[i, i] += eta * p.D[i, i]
        else:
            J[i, i] = 1.0 / r[i]
            if b == BRANCH_SLIP_POS or b == BRANCH_SLIP_NEG:
                s = 1.0 if b == BRANCH_SLIP_POS else -1.0
                J[i, p.pair[i]] = -p.mu_row[i] * s / r[i]
    lu_factor(J, m, w.piv)


@stage
def _velocity_line_search(p, w):
    """Backtracking on the squared 2-norm of the residual (the max-norm stalls) from ``p.lam``
    along ``w.dl``. Returns (theta of the smallest merit, theta of the last trial)."""
    m = p.lam.shape[0]
    F = w.F
    F_try = w.F_try
    merit = 0.0
    for i in range(m):
        merit += F[i] * F[i]
    theta = 1.0
    best = -1.0
    best_theta = 1.0
    for _ls in range(LINE_SEARCH_TRIALS):
        for i in range(m):
            w.lam_try[i] = p.lam[i] + theta * w.dl[i]
        _residual(p, w.lam_try, w.r, w.xi_try, F_try)
        merit_try = 0.0
        for i in range(m):
            merit_try += F_try[i] * F_try[i]
        if best < 0.0 or merit_try < best:
            best = merit_try
            best_theta = theta
        if merit_try <= (1.0 - 1e-4 * theta) * merit:
            break
        theta *= 0.5
    return best_theta, theta


@stage
def _newton_velocity(p, tol, max_iter, eta, w):
    """Semismooth Newton on the problem ``p`` from its impulses; returns (iterations, residual
    [m/s]). At least one Newton step: the problem is piecewise linear, so one step on the
    right active set is exact, while a warm start that merely meets the tolerance leaves
    velocity errors of order tol that show up as force chatter in persistent contact (tol m /
    h). It iterates to half the tolerance: the admissibility projection at exit may move the
    residual by a comparable amount."""
    m = p.lam.shape[0]
    lam = p.lam
    res = _residual(p, lam, w.r, w.xi, w.F)
    iters = 0
    while (res > 0.5 * tol or iters == 0) and iters < max_iter and m > 0:
        iters += 1
        # where no row changed branch since the last iteration, the factors are reused
        if not _law_branches(p, iters == 1, w):
            _factor_velocity_newton(p, eta, w)
        for i in range(m):
            w.dl[i] = -w.F[i]
        lu_solve(w.J, m, w.piv, w.dl)
        best_theta, last_theta = _velocity_line_search(p, w)
        for i in range(m):
            lam[i] += best_theta * w.dl[i]
        if best_theta == last_theta:
            # the last trial is the new iterate: reuse its velocities and residual
            copy_vector(w.xi, w.xi_try, m)
            copy_vector(w.F, w.F_try, m)
            res = 0.0
            for i in range(m):
                res = max(res, abs(w.F[i]))
        else:
            res = _residual(p, lam, w.r, w.xi, w.F)
    return iters, res


@stage
def _gauss_seidel(p, tol, max_iter, res, w):
    """Fallback where the Newton iteration stalled (redundant frictional contacts): nonsmooth
    block Gauss-Seidel, each contact's normal/tangent pair solved exactly by enumerating
    open, stick and the two slip directions; slow but robust. Returns (sweeps, residual)."""
    m = p.lam.shape[0]
    D = p.D
    c = p.c
    kind = p.kind
    mu_row = p.mu_row
    pair = p.pair
    lam = p.lam
    r = w.r
    sweeps = 0
    for _sweep in range(SWEEPS_PER_ITERATION * max_iter):
        sweeps += 1
        i = np.int64(0)  # not a literal 0, which compiles a second specialisation
        while i < m:
            if (kind[i] == ROW_NORMAL and i + 1 < m and kind[i + 1] == ROW_TANGENT
                    and pair[i + 1] == i):
                _local_frictional_contact(D, c, lam, i, mu_row[i + 1])
                i += 2
                continue
            xi_i = c[i]
            for j in range(m):
                xi_i += D[i, j] * lam[j]
            if kind[i] == ROW_JOINT:
                lam[i] = lam[i] - r[i] * xi_i
            elif kind[i] == ROW_NORMAL:
                lam[i] = max(0.0, lam[i] - r[i] * xi_i)
            else:
                bound = mu_row[i] * max(lam[pair[i]], 0.0)
                lam[i] = min(max(lam[i] - r[i] * xi_i, -bound), bound)
            i += 1
        res = _residual(p, lam, w.r, w.xi, w.F)
        if res <= 0.5 * tol:
            break
    return sweeps, res


@stage
def _make_admissible(p, res, w):
    """Make the impulses admissible exactly (Lambda_N >= 0, |Lambda_T| <= mu Lambda_N) once the
    law holds to the tolerance, which moves the velocities by less than tol; returns the
    residual afterwards (``res`` if nothing moved: xi and F are those of the impulses)."""
    lam = p.lam
    kind = p.kind
    m = lam.shape[0]
    moved = False
    for i in range(m):
        if kind[i] == ROW_NORMAL and lam[i] < 0.0:
            lam[i] = 0.0
            moved = True
    for i in range(m):
        if kind[i] == ROW_TANGENT:
            bound = p.mu_row[i] * lam[p.pair[i]]
            clipped = min(max(lam[i], -bound), bound)
            if clipped != lam[i]:
                lam[i] = clipped
                moved = True
    if moved:
        return _residual(p, lam, w.r, w.xi, w.F)
    return res


def solve_velocity_problem(D, c, kind, mu_row, pair, lam, tol, max_iter, eta,
                           newton_after_fallback=0):
    """Solve xi = D lam + c with xi_b = 0 (joints), Newton's law 0 <= xi_N ⊥ lam_N >= 0 and
    Coulomb's law |lam_T| <= mu lam_N (stick xi_T = 0, else lam_T opposes xi_T).

    Semismooth Newton with Delassus-scaled augmentation, proximal regularisation and a line
    search; projected Gauss-Seidel as fallback; with ``newton_after_fallback`` (1: a retried
    step's) Newton again from the fallback's iterate where that did not converge either.
    ``lam`` holds the warm start on entry and the solution on exit. Returns (iterations,
    converged). (Allocates its work arrays; the time loop calls
    :func:`_solve_velocity_problem` with arrays made once per run.)"""
    return _solve_velocity_problem(D, c, kind, mu_row, pair, lam, tol, max_iter, eta,
                                   newton_after_fallback, velocity_solver_work(lam.shape[0]))


@stage
def _newton_after_fallback(p, tol, max_iter, eta, res, w):
    """Newton again from the Gauss-Seidel fallback's iterate, kept only where it ends with a
    smaller residual. Where the fallback stalls it converges slowly along the problem's
    softest mode (in a ring of balls pinched between both rings, the rings' motion), while
    Newton from the warm start cycles between branches; from near the solution Newton's
    branches are right and it finishes in one or two iterations. Returns (iterations,
    residual)."""
    m = p.lam.shape[0]
    copy_vector(w.lam_keep, p.lam, m)
    iters, res_newton = _newton_velocity(p, tol, max_iter, eta, w)
    if res_newton < res:
        return iters, res_newton
    copy_vector(p.lam, w.lam_keep, m)
    return iters, _residual(p, p.lam, w.r, w.xi, w.F)


@step_kernel
def _solve_velocity_problem(D, c, kind, mu_row, pair, lam, tol, max_iter, eta,
                            newton_after_fallback, sw):
    """:func:`solve_velocity_problem` on the work arrays ``sw`` (:func:`velocity_solver_work`):
    semismooth Newton, the Gauss-Seidel fallback if it did not reach half the tolerance, with
    ``newton_after_fallback`` Newton again if neither did, then the admissibility projection.
    Returns (iterations + fallback sweeps, converged)."""
    m = lam.shape[0]
    p = VelocityProblem(D, c, kind, mu_row, pair, lam)
    w = VelocitySolverWork(sw.r[:m], sw.F[:m], sw.F_try[:m], sw.xi[:m], sw.xi_try[:m],
                           sw.lam_try[:m], sw.dl[:m], sw.J, sw.piv, sw.branch,
                           sw.lam_keep[:m])
    for i in range(m):
        w.r[i] = 1.0
        if D[i, i] > 0.0:
            w.r[i] = 1.0 / D[i, i]
    iters, res = _newton_velocity(p, tol, max_iter, eta, w)
    if res > 0.5 * tol:
        sweeps, res = _gauss_seidel(p, tol, max_iter, res, w)
        iters += sweeps
        if newton_after_fallback and res > 0.5 * tol:
            more, res = _newton_after_fallback(p, tol, max_iter, eta, res, w)
            iters += more
    res = _make_admissible(p, res, w)
    return iters, res <= tol


# -- the velocity jump -----------------------------------------------------------------------

@stage
def _jump_metric(q1, v_t, h, ma, f_t, jm):
    """Av = M + h C (C: the springs' damping at (q1, v~), on the springs' blocks and the
    diagonal, see the position correction's metric) factorised, b = h (f(q1, v~) - f~) and
    Ab = Av^-1 b, into ``jm`` (:data:`JumpMetric`; the stiffness is not needed here)."""
    mdiag = ma.mdiag
    n = q1.shape[0]
    f1 = jm.f1
    C1 = jm.C1
    Av = jm.Av
    b = jm.b
    smooth_forces_into(q1, v_t, ma, f1, C1, C1, C1, FORCES_ONLY, jm.fw, jm.iw)
    spring_damping_into(q1, v_t, ma, C1, jm.fw, jm.iw)
    scale_pair_blocks(Av, C1, h, ma.sp_body)
    for i in range(n):
        Av[i, i] = h * C1[i, i] + mdiag[i]
        b[i] = h * (f1[i] - f_t[i])
    block_factor(Av, n, jm.fac, SYMMETRIC)
    copy_vector(jm.Ab, b, n)
    block_solve(jm.fac, n, jm.Ab)


@stage
def _jump_rows(q1, v_t, t1, gap_close, ma, nu_c, gap, state, jr):
    """The rows of the velocity problem into ``jr`` (:data:`JumpRows`): the joints', then a
    normal row and (with friction) a tangential row for each contact closed after the position
    correction (nu_N > 0 or g_N <= gap_close [m]), with their offsets (the joints' dg/dt, the
    restitution terms), the warm start of their impulses (the previous step's) and supports.
    Zeroes the contacts' impulses ``state.lamN``/``lamT``. Returns the number of rows."""
    ct_body = ma.ct_body
    ct_law = ma.ct_law
    n = q1.shape[0]
    nbil = jr.gb.shape[0]
    nc = ma.ct_type.shape[0]
    Gb = jr.Gb
    dgdt = jr.dgdt
    trig = jr.trig
    wN = jr.wN
    wT = jr.wT
    bilateral_cached(q1, v_t, t1, ma, jr.gb, Gb, jr.gm, dgdt, trig)
    closed = jr.closed
    n_rows = nbil
    for k in range(nc):
        closed[k] = nu_c[k] > 0.0 or gap[k] <= gap_close
        if closed[k]:
            n_rows += 2 if ct_law[k, 0] > 0.0 else 1
    G = jr.G
    off = jr.off
    kind = jr.kind
    mu_row = jr.mu_row
    pair = jr.pair
    lam = jr.lam
    row_of = jr.row_of
    row_of[:] = -1
    cols = jr.cols
    ncols = jr.ncols
    lam_b = state.lam_b
    lamN = state.lamN
    lamT = state.lamT
    joint_support(ma.jt_type, ma.jt_body, cols, ncols)
    for r in range(nbil):
        for i in range(n):
            G[r, i] = Gb[r, i]
        off[r] = dgdt[r]
        kind[r] = ROW_JOINT
        mu_row[r] = 0.0
        pair[r] = 0
        lam[r] = lam_b[r] if lam_b.shape[0] == nbil else 0.0
    row = nbil
    for k in range(nc):
        lamN_prev = lamN[k]
        lamT_prev = lamT[k]
        lamN[k] = 0.0
        lamT[k] = 0.0
        if not closed[k]:
            continue
        contact_rows_cached(q1, k, ma.ct_type, ma.ct_body, ma.ct_geom, wN, wT, trig)
        scatter_row(G[row], wN, ct_body[k, 0], ct_body[k, 1])
        ncols[row] = pair_support(ct_body[k, 0], ct_body[k, 1], cols, row)
        # Newton's law as docs/model.md states it, with the start-of-step velocity also where
        # the contact was separating then (closed by the position correction, e.g. the partner
        # of a pinched ball): xi_N = dg_N+ + e_N dg_N- may then leave it slightly approaching.
        # Clipping dg_N- at 0 there was tried: with several simultaneous Newton laws around a
        # pinched ball it fed energy into the paper's case (a blow-up within 20 ms).
        off[row] = ct_law[k, 1] * state.vn[k]
        kind[row] = ROW_NORMAL
        mu_row[row] = 0.0
        pair[row] = 0
        lam[row] = lamN_prev
        row_of[k] = row
        row += 1
        if ct_law[k, 0] > 0.0:
            scatter_row(G[row], wT, ct_body[k, 0], ct_body[k, 1])
            ncols[row] = pair_support(ct_body[k, 0], ct_body[k, 1], cols, row)
            off[row] = ct_law[k, 2] * state.vt[k]
            kind[row] = ROW_TANGENT
            mu_row[row] = ct_law[k, 0]
            pair[row] = row - 1
            lam[row] = lamT_prev
            row += 1
    return n_rows


@stage
def _delassus(v_t, n_rows, jm, jr, jp):
    """Delassus matrix D = G Av^-1 G^T and free velocity c = G (v~ + Av^-1 b) + off of the
    problem's first ``n_rows`` rows, into ``jp`` (:data:`JumpProblem`)."""
    c = jp.c
    G = jr.G
    off = jr.off
    Ab = jm.Ab
    cols = jr.cols
    ncols = jr.ncols
    block_gram(jm.fac, G, n_rows, jp.Y, jp.first, jp.D, cols, ncols)
    for a in range(n_rows):
        s = off[a]
        for t in range(ncols[a]):
            i = cols[a, t]
            s += G[a, i] * (v_t[i] + Ab[i])
        c[a] = s


@stage
def _eliminate_joints(nbil, nct, jr, jp):
    """The contact problem that remains once the joints (equalities, the first ``nbil`` rows)
    are eliminated: Dc = Dcc - Dcb Dbb^-1 Dbc and cc = c_c - Dcb Dbb^-1 c_b over the ``nct``
    contact rows, with X = Dbb^-1 [Dbc, c_b] kept for :func:`_joint_impulses`; the contact
    impulses' warm start into ``lam_c``."""
    D = jp.D
    c = jp.c
    Dbb = jp.Dbb
    pivb = jp.pivb
    for a in range(nbil):
        for c2 in range(nbil):
            Dbb[a, c2] = D[a, c2]
    lu_factor(Dbb, nbil, pivb)
    # X = Dbb^-1 [Dbc, c_b], one column at a time
    X = jp.X  # its leading nbil x (nct + 1) block
    col = jp.colb
    for j in range(nct + 1):
        for a in range(nbil):
            col[a] = D[a, nbil + j] if j < nct else c[a]
        lu_solve(Dbb, nbil, pivb, col)
        for a in range(nbil):
            X[a, j] = col[a]
    Dc = jp.Dc  # its leading nct x nct block
    cc = jp.cc
    lam_c = jp.lam_c
    pair_c = jp.pair_c
    lam = jr.lam
    pair = jr.pair
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


@stage
def _joint_impulses(nbil, nct, tol, jr, jp):
    """The joints' impulses from the contacts' (lam_b = -X [lam_c; 1]) into ``jr.lam``; returns
    whether the joints then hold to ``tol`` [m/s] (round-off only)."""
    n_rows = nbil + nct
    lam = jr.lam
    lam_c = jp.lam_c
    X = jp.X
    D = jp.D
    for a in range(nct):
        lam[nbil + a] = lam_c[a]
    for p in range(nbil):
        s = X[p, nct]
        for j in range(nct):
            s += X[p, j] * lam_c[j]
        lam[p] = -s
    ok = True
    for r in range(nbil):
        xi_b = jp.c[r]
        for j in range(n_rows):
            xi_b += D[r, j] * lam[j]
        if abs(xi_b) > tol:
            ok = False
    return ok


@stage
def _solve_jump(nbil, n_rows, st, jr, jp, sw):
    """Solve the velocity problem of the rows: with joints and contacts, the joints are
    eliminated first (the contact problem then sees the mechanism's effective masses, and its
    Gauss-Seidel fallback converges); otherwise the problem is solved as it is. Returns
    (iterations, converged)."""
    tol = st.tol
    if nbil > 0 and n_rows > nbil:
        nct = n_rows - nbil
        _eliminate_joints(nbil, nct, jr, jp)
        iters, ok = _solve_velocity_problem(jp.Dc, jp.cc[:nct], jr.kind[nbil:n_rows],
                                            jr.mu_row[nbil:n_rows], jp.pair_c[:nct],
                                            jp.lam_c[:nct], tol, st.max_iter, st.eta,
                                            st.newton_after_fallback, sw)
        return iters, _joint_impulses(nbil, nct, tol, jr, jp) and ok
    Dv = jp.Dc  # its leading n_rows x n_rows block
    D = jp.D
    for a in range(n_rows):
        for j in range(n_rows):
            Dv[a, j] = D[a, j]
    return _solve_velocity_problem(Dv, jp.c[:n_rows], jr.kind[:n_rows], jr.mu_row[:n_rows],
                                   jr.pair[:n_rows], jr.lam[:n_rows], tol, st.max_iter,
                                   st.eta, st.newton_after_fallback, sw)


@stage
def _apply_jump(v_t, n_rows, ma, v1, state, jm, jr):
    """v1 = v~ + W with W = Av^-1 (b + G^T Lambda); the joints' and contacts' impulses into
    ``state.lam_b``, ``state.lamN``, ``state.lamT``."""
    n = v_t.shape[0]
    nbil = jr.gb.shape[0]
    G = jr.G
    lam = jr.lam
    cols = jr.cols
    ncols = jr.ncols
    row_of = jr.row_of
    W = jm.W
    b = jm.b
    for i in range(n):
        W[i] = b[i]
    for r in range(n_rows):
        for t in range(ncols[r]):
            i = cols[r, t]
            W[i] += G[r, i] * lam[r]
    block_solve(jm.fac, n, W)
    for i in range(n):
        v1[i] = v_t[i] + W[i]
    for r in range(nbil):
        state.lam_b[r] = lam[r]
    for k in range(ma.ct_type.shape[0]):
        rk = row_of[k]
        if rk >= 0:
            state.lamN[k] = lam[rk]
            if ma.ct_law[k, 0] > 0.0:
                state.lamT[k] = lam[rk + 1]


@step_kernel
def velocity_step(q1, v_t, t1, h, st, ma, f_t, nu_c, gap, state, v1, wk):
    """Velocity jump W = v1 - v~ with impulses Lambda on the joints and on the contacts closed
    after the position correction (nu_N > 0 or g_N <= tol h).

    Parameters
    ----------
    q1 : ndarray
        Corrected coordinates [m, rad].
    v_t : ndarray
        Velocities of the smooth stage v~ [m/s, rad/s].
    t1 : float
        Time at the end of the step [s].
    h : float
        Step [s].
    st : StepSettings
        ``tol`` [m/s], ``max_iter``, ``eta`` [-].
    ma : ModelArrays
        The model.
    f_t : ndarray
        Smooth forces at (q~, v~) [N, N m].
    nu_c, gap : ndarray
        The position correction's contact multipliers [kg m] and gaps [m].
    state : StepState
        ``vn``, ``vt``: the contacts' velocities at the start of the step (Newton's law's
        pre-impact velocities) [m/s]; ``lamN``, ``lamT``, ``lam_b``: the previous step's
        impulses on entry (warm start), this step's on exit [N s].
    v1 : ndarray
        Receives v~ + W [m/s, rad/s].
    wk : VelocityWork
        Work arrays (:func:`velocity_work`).

    Returns
    -------
    (int, bool)
        Newton iterations (with the fallback's sweeps), converged.
    """
    jm = wk.metric
    jr = wk.rows
    jp = wk.problem
    _jump_metric(q1, v_t, h, ma, f_t, jm)
    n_rows = _jump_rows(q1, v_t, t1, st.tol * h, ma, nu_c, gap, state, jr)
    _delassus(v_t, n_rows, jm, jr, jp)
    iters, ok = _solve_jump(jr.gb.shape[0], n_rows, st, jr, jp, wk.solver)
    _apply_jump(v_t, n_rows, ma, v1, state, jm, jr)
    return iters, ok
