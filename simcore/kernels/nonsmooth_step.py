"""The decoupled nonsmooth generalized-alpha step: after the smooth stage
(:mod:`.generalized_alpha`), a position correction (joints and unilateral contacts) and a
velocity jump (Newton's impact law and Coulomb friction), and the time loop over a chunk of
steps."""

from __future__ import annotations

import numpy as np
from numba import njit

from .bodies import scatter_row
from .contact import contact_hessian, contact_rows, contact_velocities
from .generalized_alpha import alpha_coefficients, smooth_step
from .joints import bilateral, joint_row_count
from .linalg import block_inverse
from .springs import smooth_forces, total_energy

# layout of the per-step statistics written by integrate_chunk
STAGE_SMOOTH = 0
STAGE_POSITION = 1
STAGE_VELOCITY = 2



@njit(cache=True)
def _position_residual(q_t, U, nu_b, nu_c, t1, h, ma, Ap, r_c, gb, Gb, gap, GN, q1):
    """Scaled residual [m] of the position problem at (U, nu): joints, complementarity in the
    augmented-Lagrangian form (nu - max(0, nu - r g))/r, and equilibrium M^-1 (Ap U - G^T nu).
    Also refreshes joint and contact rows at q1 = q_t + U."""
    mdiag = ma.mdiag
    ct_type = ma.ct_type
    ct_body = ma.ct_body
    n = q_t.shape[0]
    for i in range(n):
        q1[i] = q_t[i] + U[i]
    gm = np.zeros(gb.shape[0])
    dgdt = np.zeros(gb.shape[0])
    bilateral(q1, U, t1, ma, gb, Gb, gm, dgdt)
    wN = np.zeros(6)
    wT = np.zeros(6)
    res = 0.0
    for r in range(gb.shape[0]):
        res = max(res, abs(gb[r]))
    for k in range(ct_type.shape[0]):
        gap[k] = contact_rows(q1, k, ma, wN, wT)
        scatter_row(GN[k], wN, ct_body[k, 0], ct_body[k, 1])
        rk = r_c[k]
        val = nu_c[k] - max(0.0, nu_c[k] - rk * gap[k])
        res = max(res, abs(val) / rk)
    eq = Ap @ U - Gb.T @ nu_b - GN.T @ nu_c
    for i in range(n):
        res = max(res, abs(eq[i]) / mdiag[i])
    return res


@njit(cache=True)
def position_step(q_t, t1, h, tol, max_iter, eta, ma, Ks_t, q1, nu_c, gap):
    """Position correction: M U = G^T nu (with the springs' elastic stiffness h^2 Ks in the
    metric, symmetric positive semi-definite so that the metric stays positive definite),
    joints g(q_t + U) = 0 and 0 <= g_N ⊥ nu_N >= 0 for every contact.

    Semismooth Newton with Delassus-scaled augmentation r_j = 1/(G_j A^-1 G_j^T), a proximal
    term (eta/r)(nu - nu_k) on active rows for redundant (pinched) contacts, and a backtracking
    line search on the scaled residual. Returns (iterations, converged)."""
    mdiag = ma.mdiag
    ct_type = ma.ct_type
    ct_body = ma.ct_body
    n = q_t.shape[0]
    nbil = joint_row_count(ma.jt_type)
    nc = ct_type.shape[0]
    Ap = np.empty((n, n))
    for i in range(n):
        for j in range(n):
            Ap[i, j] = h * h * Ks_t[i, j]
        Ap[i, i] += mdiag[i]
    Ainv = block_inverse(Ap)
    U = np.zeros(n)
    nu_b = np.zeros(nbil)
    nu_c[:] = 0.0
    gb = np.zeros(nbil)
    Gb = np.zeros((nbil, n))
    GN = np.zeros((nc, n))
    r_c = np.ones(nc)
    # Delassus scaling from the rows at the predicted configuration
    res = _position_residual(q_t, U, nu_b, nu_c, t1, h, ma, Ap, r_c, gb, Gb, gap, GN, q1)
    for k in range(nc):
        dkk = GN[k] @ (Ainv @ GN[k])
        r_c[k] = 1.0 / dkk if dkk > 0.0 else 1.0
    res = _position_residual(q_t, U, nu_b, nu_c, t1, h, ma, Ap, r_c, gb, Gb, gap, GN, q1)
    target = tol * h
    iters = 0
    converged = res <= target
    active = np.zeros(nc, dtype=np.bool_)
    U_try = np.zeros(n)
    nub_try = np.zeros(nbil)
    nuc_try = np.zeros(nc)
    gb_try = np.zeros(nbil)
    Gb_try = np.zeros((nbil, n))
    gap_try = np.zeros(nc)
    GN_try = np.zeros((nc, n))
    q_try = np.zeros(n)
    Hloc = np.zeros((6, 6))
    eta_k = eta
    Gall = np.zeros((nbil + nc, n))
    ball = np.zeros(nbil + nc)
    reg_c = np.zeros(nc)
    rows = np.arange(nbil + nc)  # rows[:nbil] are the joints, always present
    # at least one Newton step, so that the joints are restored to round-off at every step
    # (a drift below tol*h would otherwise accumulate up to that level)
    while (not converged or iters == 0) and iters < max_iter:
        iters += 1
        for k in range(nc):
            active[k] = nu_c[k] - r_c[k] * gap[k] > 0.0
        # Newton matrix of the equilibrium: A - sum nu_j d2g_j (contact geometric stiffness)
        Hinv = Ainv
        if nu_c.max() > 0.0:
            Hm = Ap.copy()
            for k in range(nc):
                if nu_c[k] > 0.0:
                    contact_hessian(q1, k, ma, Hloc)
                    for a in range(6):
                        ba = ct_body[k, 0] if a < 3 else ct_body[k, 1]
                        if ba < 0:
                            continue
                        for c in range(6):
                            bc = ct_body[k, 0] if c < 3 else ct_body[k, 1]
                            if bc < 0:
                                continue
                            Hm[3 * ba + a % 3, 3 * bc + c % 3] -= nu_c[k] * Hloc[a, c]
            Hinv = block_inverse(Hm)
        # the linearised problem of this iterate, for all rows: joints first, then contacts;
        # row i of the new iterate reads (D nu)_i = b_i (+ proximal term on contacts)
        HAU = Hinv @ (Ap @ U)
        for r in range(nbil):
            Gall[r] = Gb[r]
            ball[r] = -gb[r] + Gb[r] @ HAU
        for k in range(nc):
            Gall[nbil + k] = GN[k]
            ball[nbil + k] = -gap[k] + GN[k] @ HAU
            reg_c[k] = eta_k / r_c[k]
        AGall = Hinv @ Gall.T
        Dall = Gall @ AGall
        # exact active set of the linearised problem (primal-dual active set): drop contacts
        # whose multiplier turns negative, add those whose linearised gap turns negative;
        # one geometric Newton step then never cycles on a degenerate contact
        for _inner in range(8 * nc * nc + 8):
            m = nbil
            for k in range(nc):
                if active[k]:
                    rows[m] = nbil + k
                    m += 1
            D = np.empty((m, m))
            rhs = np.empty(m)
            for a in range(m):
                ra = rows[a]
                for c in range(m):
                    D[a, c] = Dall[ra, rows[c]]
                rhs[a] = ball[ra]
                if ra >= nbil:
                    D[a, a] += reg_c[ra - nbil]
                    rhs[a] += reg_c[ra - nbil] * nu_c[ra - nbil]
            sol = np.linalg.solve(D, rhs)
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
                    lin_gap = -ball[nbil + k]
                    for a in range(m):
                        lin_gap += Dall[nbil + k, rows[a]] * sol[a]
                    if lin_gap < -0.1 * target:
                        flip = k
                        break
            if flip < 0:
                break
            active[flip] = not active[flip]
        U_new = U - HAU
        for a in range(m):
            U_new += AGall[:, rows[a]] * sol[a]
        nub_new = sol[:nbil]
        nuc_new = np.zeros(nc)
        for a in range(nbil, m):
            nuc_new[rows[a] - nbil] = sol[a]
        # backtracking line search on the scaled residual
        theta = 1.0
        best = -1.0
        best_theta = 1.0
        for _ls in range(12):
            for i in range(n):
                U_try[i] = U[i] + theta * (U_new[i] - U[i])
            for r in range(nbil):
                nub_try[r] = nu_b[r] + theta * (nub_new[r] - nu_b[r])
            for k in range(nc):
                nuc_try[k] = nu_c[k] + theta * (nuc_new[k] - nu_c[k])
            res_try = _position_residual(q_t, U_try, nub_try, nuc_try, t1, h, ma, Ap, r_c,
                                         gb_try, Gb_try, gap_try, GN_try, q_try)
            if best < 0.0 or res_try < best:
                best = res_try
                best_theta = theta
            if res_try <= (1.0 - 1e-4 * theta) * res:
                break
            theta *= 0.5
        theta = best_theta
        if theta < 0.125:
            # the active set cycles (the full step does not reduce the residual): stiffen the
            # proximal term so that the multipliers move less per iteration
            eta_k = min(100.0 * eta_k, 1e-1)
        elif theta == 1.0:
            eta_k = max(eta, 0.01 * eta_k)  # back towards plain Newton once steps go through
        for i in range(n):
            U[i] += theta * (U_new[i] - U[i])
        for r in range(nbil):
            nu_b[r] += theta * (nub_new[r] - nu_b[r])
        for k in range(nc):
            nu_c[k] += theta * (nuc_new[k] - nu_c[k])
        res = _position_residual(q_t, U, nu_b, nu_c, t1, h, ma, Ap, r_c, gb, Gb, gap, GN, q1)
        converged = res <= target
    return iters, converged


@njit(cache=True)
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


@njit(cache=True)
def _local_frictional_contact(D, c, lam, i, mu):
    """Solve one contact's rows (normal i, tangent i+1) exactly, the others held fixed."""
    j = i + 1
    bN = D[i] @ lam + c[i] - D[i, i] * lam[i] - D[i, j] * lam[j]
    bT = D[j] @ lam + c[j] - D[j, i] * lam[i] - D[j, j] * lam[j]
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


@njit(cache=True)
def solve_velocity_problem(D, c, kind, mu_row, pair, lam, tol, max_iter, eta):
    """Solve xi = D lam + c with xi_b = 0 (joints), Newton's law 0 <= xi_N ⊥ lam_N >= 0 and
    Coulomb's law |lam_T| <= mu lam_N (stick xi_T = 0, else lam_T opposes xi_T).

    Semismooth Newton with Delassus-scaled augmentation, proximal regularisation and a line
    search; projected Gauss-Seidel as fallback. ``lam`` holds the warm start on entry and the
    solution on exit. Returns (iterations, converged)."""
    m = lam.shape[0]
    r = np.ones(m)
    for i in range(m):
        if D[i, i] > 0.0:
            r[i] = 1.0 / D[i, i]
    F = np.zeros(m)
    F_try = np.zeros(m)
    xi = D @ lam + c
    res = _velocity_residual(lam, xi, kind, r, mu_row, pair, F)
    iters = 0
    J = np.zeros((m, m))
    lam_try = np.zeros(m)
    # at least one Newton step: the problem is piecewise linear, so one step on the right
    # active set is exact, while a warm start that merely meets the tolerance leaves velocity
    # errors of order tol that show up as force chatter in persistent contact (tol m / h)
    # iterate to half the tolerance: the admissibility projection at exit may move the
    # residual by a comparable amount
    while (res > 0.5 * tol or iters == 0) and iters < max_iter and m > 0:
        iters += 1
        J[:, :] = 0.0
        for i in range(m):
            if kind[i] == 0:
                J[i] = D[i]
            elif kind[i] == 1:
                if lam[i] - r[i] * xi[i] > 0.0:
                    J[i] = D[i]
                    J[i, i] += eta * D[i, i]
                else:
                    J[i, i] = 1.0 / r[i]
            else:
                bound = mu_row[i] * max(lam[pair[i]], 0.0)
                z = lam[i] - r[i] * xi[i]
                if abs(z) < bound:
                    J[i] = D[i]
                    J[i, i] += eta * D[i, i]
                else:
                    J[i, i] = 1.0 / r[i]
                    if lam[pair[i]] > 0.0:
                        s = 1.0 if z > 0.0 else -1.0
                        J[i, pair[i]] = -mu_row[i] * s / r[i]
        dl = np.linalg.solve(J, -F)
        # backtracking on the squared 2-norm of the residual (the max-norm stalls)
        merit = F @ F
        theta = 1.0
        best = -1.0
        best_theta = 1.0
        for _ls in range(12):
            lam_try[:] = lam + theta * dl
            xi_try = D @ lam_try + c
            _velocity_residual(lam_try, xi_try, kind, r, mu_row, pair, F_try)
            merit_try = F_try @ F_try
            if best < 0.0 or merit_try < best:
                best = merit_try
                best_theta = theta
            if merit_try <= (1.0 - 1e-4 * theta) * merit:
                break
            theta *= 0.5
        lam += best_theta * dl
        xi = D @ lam + c
        res = _velocity_residual(lam, xi, kind, r, mu_row, pair, F)
    if res > 0.5 * tol:
        # fallback: nonsmooth block Gauss-Seidel (each contact's normal/tangent pair solved
        # exactly by enumerating open, stick and the two slip directions), slow but robust
        # where redundant frictional contacts make the Newton iteration stall
        for _sweep in range(200 * max_iter):
            iters += 1
            i = 0
            while i < m:
                if kind[i] == 1 and i + 1 < m and kind[i + 1] == 2 and pair[i + 1] == i:
                    _local_frictional_contact(D, c, lam, i, mu_row[i + 1])
                    i += 2
                    continue
                xi_i = D[i] @ lam + c[i]
                if kind[i] == 0:
                    lam[i] = lam[i] - r[i] * xi_i
                elif kind[i] == 1:
                    lam[i] = max(0.0, lam[i] - r[i] * xi_i)
                else:
                    bound = mu_row[i] * max(lam[pair[i]], 0.0)
                    lam[i] = min(max(lam[i] - r[i] * xi_i, -bound), bound)
                i += 1
            xi = D @ lam + c
            res = _velocity_residual(lam, xi, kind, r, mu_row, pair, F)
            if res <= 0.5 * tol:
                break
    # the law holds to the tolerance; make the impulses admissible exactly (Lambda_N >= 0,
    # |Lambda_T| <= mu Lambda_N), which moves the velocities by less than tol
    for i in range(m):
        if kind[i] == 1:
            lam[i] = max(lam[i], 0.0)
    for i in range(m):
        if kind[i] == 2:
            bound = mu_row[i] * lam[pair[i]]
            lam[i] = min(max(lam[i], -bound), bound)
    xi = D @ lam + c
    res = _velocity_residual(lam, xi, kind, r, mu_row, pair, F)
    return iters, res <= tol


@njit(cache=True)
def velocity_step(q1, q_t, v_t, t1, h, tol, max_iter, eta, gap_close, ma, f_t, nu_c, gap,
                  vn_minus, vt_minus, v1, lamN, lamT, lam_b):
    """Velocity jump W = v1 - v_t with impulses Lambda on the joints and on the contacts closed
    after the position correction (nu_N > 0 or g_N <= gap_close). ``lamN``/``lamT`` hold the
    previous step's impulses (warm start) on entry. Returns (iterations, converged)."""
    mdiag = ma.mdiag
    ct_type = ma.ct_type
    ct_body = ma.ct_body
    ct_law = ma.ct_law
    n = q1.shape[0]
    nbil = joint_row_count(ma.jt_type)
    nc = ct_type.shape[0]
    f1 = np.zeros(n)
    K1 = np.zeros((n, n))
    C1 = np.zeros((n, n))
    smooth_forces(q1, v_t, ma, f1, K1, C1, np.zeros((n, n)), True)
    Av = np.empty((n, n))
    b = np.empty(n)
    for i in range(n):
        for j in range(n):
            Av[i, j] = h * C1[i, j]
        Av[i, i] += mdiag[i]
        b[i] = h * (f1[i] - f_t[i])
    Ainv = block_inverse(Av)
    gb = np.zeros(nbil)
    Gb = np.zeros((nbil, n))
    gm = np.zeros(nbil)
    dgdt = np.zeros(nbil)
    bilateral(q1, v_t, t1, ma, gb, Gb, gm, dgdt)
    closed = np.zeros(nc, dtype=np.bool_)
    n_rows = nbil
    for k in range(nc):
        closed[k] = nu_c[k] > 0.0 or gap[k] <= gap_close
        if closed[k]:
            n_rows += 2 if ct_law[k, 0] > 0.0 else 1
    G = np.zeros((n_rows, n))
    off = np.zeros(n_rows)
    kind = np.zeros(n_rows, dtype=np.int64)
    mu_row = np.zeros(n_rows)
    pair = np.zeros(n_rows, dtype=np.int64)
    lam = np.zeros(n_rows)
    row_of = np.full(nc, -1, dtype=np.int64)
    for r in range(nbil):
        G[r] = Gb[r]
        off[r] = dgdt[r]
        lam[r] = lam_b[r] if lam_b.shape[0] == nbil else 0.0
    wN = np.zeros(6)
    wT = np.zeros(6)
    row = nbil
    for k in range(nc):
        lamN_prev = lamN[k]
        lamT_prev = lamT[k]
        lamN[k] = 0.0
        lamT[k] = 0.0
        if not closed[k]:
            continue
        contact_rows(q1, k, ma, wN, wT)
        scatter_row(G[row], wN, ct_body[k, 0], ct_body[k, 1])
        # Newton's law as SPEC section 3 states it, with the start-of-step velocity also where
        # the contact was separating then (closed by the position correction, e.g. the partner
        # of a pinched ball): xi_N = dg_N+ + e_N dg_N- may then leave it slightly approaching.
        # Clipping dg_N- at 0 there was tried: with several simultaneous Newton laws around a
        # pinched ball it fed energy into the paper's case (a blow-up within 20 ms).
        off[row] = ct_law[k, 1] * vn_minus[k]
        kind[row] = 1
        lam[row] = lamN_prev
        row_of[k] = row
        row += 1
        if ct_law[k, 0] > 0.0:
            scatter_row(G[row], wT, ct_body[k, 0], ct_body[k, 1])
            off[row] = ct_law[k, 2] * vt_minus[k]
            kind[row] = 2
            mu_row[row] = ct_law[k, 0]
            pair[row] = row - 1
            lam[row] = lamT_prev
            row += 1
    AG = Ainv @ G.T
    D = G @ AG
    c = G @ (v_t + Ainv @ b) + off
    if nbil > 0 and n_rows > nbil:
        # eliminate the joints (equalities) first: the contact problem then sees the
        # mechanism's effective masses, and its Gauss-Seidel fallback converges
        nct = n_rows - nbil
        Dbb = D[:nbil, :nbil].copy()
        Dbc = D[:nbil, nbil:].copy()
        X = np.linalg.solve(Dbb, np.hstack((Dbc, c[:nbil].reshape(nbil, 1))))
        Xl = np.ascontiguousarray(X[:, :nct])
        xc = np.ascontiguousarray(X[:, nct])
        Dcb = np.ascontiguousarray(D[nbil:, :nbil])
        Dc = np.ascontiguousarray(D[nbil:, nbil:]) - Dcb @ Xl
        cc = c[nbil:] - Dcb @ xc
        lam_c = lam[nbil:].copy()
        iters, ok = solve_velocity_problem(Dc, cc, kind[nbil:], mu_row[nbil:],
                                           pair[nbil:] - nbil, lam_c, tol, max_iter, eta)
        lam[nbil:] = lam_c
        lam[:nbil] = -(Xl @ lam_c + xc)
        # check the joints too (round-off only)
        xi_b = np.ascontiguousarray(D[:nbil]) @ lam + c[:nbil]
        for r in range(nbil):
            if abs(xi_b[r]) > tol:
                ok = False
    else:
        iters, ok = solve_velocity_problem(D, c, kind, mu_row, pair, lam, tol, max_iter, eta)
    W = Ainv @ b + AG @ lam
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


@njit(cache=True)
def integrate_chunk(k0, k1, st, ma, state, out):
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
    coef = alpha_coefficients(st.rho_inf)
    q_t = np.zeros(n)
    v_t = np.zeros(n)
    acc1 = np.zeros(n)
    vdot1 = np.zeros(n)
    f_t = np.zeros(n)
    K_t = np.zeros((n, n))
    C_t = np.zeros((n, n))
    Ks_t = np.zeros((n, n))
    q1 = np.zeros(n)
    v1 = np.zeros(n)
    nu_c = np.zeros(nc)
    gap = np.zeros(nc)
    vn = np.zeros(nc)
    vt = np.zeros(nc)
    gap_free = np.zeros(nc)
    vn_free = np.zeros(nc)
    vt_free = np.zeros(nc)
    gap_close = tol * h
    no_vpre = np.zeros(0)
    no_work = np.zeros((11, 0))
    first_bad = -1
    for k in range(k0, k1):
        t1 = (k + 1) * h
        it_s, ok_s = smooth_step(q, v, acc, vdot, lam_s, t1, h, coef, tol, max_iter, ma,
                                 q_t, v_t, acc1, vdot1, f_t, K_t, C_t, Ks_t, False, no_vpre,
                                 1.0, no_work)
        it_p, ok_p = position_step(q_t, t1, h, tol, max_iter, eta, ma, Ks_t, q1, nu_c, gap)
        contact_velocities(q1, v_t, ma, gap_free, vn_free, vt_free)
        it_v, ok_v = velocity_step(q1, q_t, v_t, t1, h, tol, max_iter, eta, gap_close, ma, f_t,
                                   nu_c, gap, vn_prev, vt_prev, v1, lamN_prev, lamT_prev, lam_b)
        # accept the step
        for i in range(n):
            q[i] = q1[i]
            v[i] = v1[i]
            acc[i] = acc1[i]
            vdot[i] = vdot1[i]
        contact_velocities(q, v, ma, gap, vn, vt)
        out.q[k + 1] = q
        out.v[k + 1] = v
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
