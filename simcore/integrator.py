"""Numba kernels: planar rigid bodies, joints, springs, unilateral contacts and the decoupled
nonsmooth generalized-alpha step (SPEC section 4).

Every kernel works on plain NumPy arrays. They call each other, so they live in this one module:
Numba's on-disk cache does not notice edits to functions in other modules.

Conventions
-----------
- ``q``, ``v``: generalized coordinates and velocities, 3 per body: (x [m], y [m], phi [rad]).
- The mass matrix is diagonal: (m, m, Izz) per body, about the body's centre of mass.
- Body index -1 is the ground; its "local" points are world points.
- A contact pairs a surface body ``a`` (plane, race) with a sphere on body ``b`` (ball). Its gap
  ``g_N`` is positive when open; its rows ``wN``/``wT`` hold the 3 + 3 Jacobian entries of bodies
  a and b, so that ``dg_N/dt = wN . (v_a, v_b)`` and the tangential slip is ``wT . (v_a, v_b)``
  with ``t = e_z x n`` and ``n`` the element's normal (SPEC section 3).
"""

from __future__ import annotations

import numpy as np
from numba import njit

# element codes shared with simcore.model
JOINT_REVOLUTE = 0
JOINT_PRISMATIC = 1
JOINT_ANGLE = 2
CONTACT_PLANE = 0
CONTACT_OUTSIDE = 1
CONTACT_INSIDE = 2

# layout of the per-step statistics written by integrate_chunk
STAGE_SMOOTH = 0
STAGE_POSITION = 1
STAGE_VELOCITY = 2


# ----------------------------------------------------------------------------------------------
# kinematics of body points
# ----------------------------------------------------------------------------------------------
@njit(cache=True)
def body_point(q, body, px, py):
    """World position (x, y) and lever arm (ax, ay) = R(phi) p of a body-fixed point [m]."""
    if body < 0:
        return px, py, 0.0, 0.0
    phi = q[3 * body + 2]
    c = np.cos(phi)
    s = np.sin(phi)
    ax = c * px - s * py
    ay = s * px + c * py
    return q[3 * body] + ax, q[3 * body + 1] + ay, ax, ay


@njit(cache=True)
def body_omega(v, body):
    """Angular velocity of a body [rad/s] (0 for the ground)."""
    if body < 0:
        return 0.0
    return v[3 * body + 2]


@njit(cache=True)
def unit_direction(dx, dy):
    """Length of (dx, dy) and its unit vector ((1, 0) for a zero vector)."""
    length = np.sqrt(dx * dx + dy * dy)
    if length > 1e-300:
        return length, dx / length, dy / length
    return length, 1.0, 0.0


@njit(cache=True)
def pair_point_jacobians(P, aix, aiy, ajx, ajy):
    """P (2 x 6) = d(c_j - c_i)/d(q_i, q_j) for body points with lever arms a_i, a_j."""
    P[:, :] = 0.0
    P[0, 0] = -1.0
    P[1, 1] = -1.0
    P[0, 2] = aiy
    P[1, 2] = -aix
    P[0, 3] = 1.0
    P[1, 4] = 1.0
    P[0, 5] = -ajy
    P[1, 5] = ajx


@njit(cache=True)
def transverse_form(P, nx, ny, a, c):
    """Entry (a, c) of P^T (I - n n^T) P: the change of direction of a two-point distance."""
    return (P[0, a] * ((1.0 - nx * nx) * P[0, c] - nx * ny * P[1, c])
            + P[1, a] * (-nx * ny * P[0, c] + (1.0 - ny * ny) * P[1, c]))


# ----------------------------------------------------------------------------------------------
# bilateral joints
# ----------------------------------------------------------------------------------------------
@njit(cache=True)
def joint_row_count(jt_type):
    """Number of constraint rows of each joint and in total."""
    n = 0
    for j in range(jt_type.shape[0]):
        n += 1 if jt_type[j] == JOINT_ANGLE else 2
    return n


@njit(cache=True)
def bilateral(q, v, t, jt_type, jt_body, jt_geom, g, G, gamma, dgdt):
    """Evaluate all bilateral constraints.

    Fills ``g`` (position residual [m or rad]), ``G`` (rows x ndof Jacobian), ``gamma``
    (the velocity-squared term of the acceleration constraint, G a + gamma = 0) and ``dgdt``
    (explicit time derivative, rheonomic joints) in place.
    """
    G[:, :] = 0.0
    row = 0
    for j in range(jt_type.shape[0]):
        bi = jt_body[j, 0]
        bj = jt_body[j, 1]
        p = jt_geom[j]
        kind = jt_type[j]
        if kind == JOINT_REVOLUTE:
            xi, yi, aix, aiy = body_point(q, bi, p[0], p[1])
            xj, yj, ajx, ajy = body_point(q, bj, p[2], p[3])
            wi = body_omega(v, bi)
            wj = body_omega(v, bj)
            g[row] = xi - xj
            g[row + 1] = yi - yj
            gamma[row] = -aix * wi * wi + ajx * wj * wj
            gamma[row + 1] = -aiy * wi * wi + ajy * wj * wj
            dgdt[row] = 0.0
            dgdt[row + 1] = 0.0
            if bi >= 0:
                G[row, 3 * bi] += 1.0
                G[row, 3 * bi + 2] += -aiy
                G[row + 1, 3 * bi + 1] += 1.0
                G[row + 1, 3 * bi + 2] += aix
            if bj >= 0:
                G[row, 3 * bj] -= 1.0
                G[row, 3 * bj + 2] -= -ajy
                G[row + 1, 3 * bj + 1] -= 1.0
                G[row + 1, 3 * bj + 2] -= ajx
            row += 2
        elif kind == JOINT_PRISMATIC:
            # body bi slides along the ground axis through (p[2], p[3]) at angle p[4];
            # its rotation is locked at p[5]
            xi, yi, aix, aiy = body_point(q, bi, p[0], p[1])
            nx = -np.sin(p[4])
            ny = np.cos(p[4])
            wi = body_omega(v, bi)
            g[row] = nx * (xi - p[2]) + ny * (yi - p[3])
            g[row + 1] = q[3 * bi + 2] - p[5]
            gamma[row] = -(nx * aix + ny * aiy) * wi * wi
            gamma[row + 1] = 0.0
            dgdt[row] = 0.0
            dgdt[row + 1] = 0.0
            G[row, 3 * bi] = nx
            G[row, 3 * bi + 1] = ny
            G[row, 3 * bi + 2] = aix * ny - aiy * nx
            G[row + 1, 3 * bi + 2] = 1.0
            row += 2
        else:
            # prescribed rotation phi = p[0] + p[1] t (rheonomic)
            g[row] = q[3 * bi + 2] - p[0] - p[1] * t
            gamma[row] = 0.0
            dgdt[row] = -p[1]
            G[row, 3 * bi + 2] = 1.0
            row += 1


# ----------------------------------------------------------------------------------------------
# smooth forces: gravity and linear spring-dampers between body points
# ----------------------------------------------------------------------------------------------
@njit(cache=True)
def spring_state(q, v, k, sp_body, sp_geom):
    """Length [m], its rate [m/s], unit direction and lever arms of spring ``k``."""
    bi = sp_body[k, 0]
    bj = sp_body[k, 1]
    p = sp_geom[k]
    xi, yi, aix, aiy = body_point(q, bi, p[0], p[1])
    xj, yj, ajx, ajy = body_point(q, bj, p[2], p[3])
    length, nx, ny = unit_direction(xj - xi, yj - yi)
    wi = body_omega(v, bi)
    wj = body_omega(v, bj)
    vix = 0.0
    viy = 0.0
    vjx = 0.0
    vjy = 0.0
    if bi >= 0:
        vix = v[3 * bi] - wi * aiy
        viy = v[3 * bi + 1] + wi * aix
    if bj >= 0:
        vjx = v[3 * bj] - wj * ajy
        vjy = v[3 * bj + 1] + wj * ajx
    dvx = vjx - vix
    dvy = vjy - viy
    rate = nx * dvx + ny * dvy
    return length, rate, nx, ny, aix, aiy, ajx, ajy, dvx, dvy


@njit(cache=True)
def smooth_forces(q, v, mass, gvec, sp_body, sp_geom, f, K, C, Ks, tangent):
    """Gravity plus spring-damper forces ``f`` [N, N m]; with ``tangent`` also the stiffness
    ``K = -df/dq`` and damping ``C = -df/dv`` matrices. K is exact for springs between body
    origins (the cage); for off-centre points the lever arms' second derivative is left out
    (Newton stays convergent, only its rate changes). ``Ks`` receives the symmetric positive
    semi-definite elastic part (axial stiffness and the geometric term of a tensile spring): it
    is the metric of the position correction, which must stay positive definite."""
    nb = mass.shape[0]
    for b in range(nb):
        f[3 * b] = mass[b] * gvec[0]
        f[3 * b + 1] = mass[b] * gvec[1]
        f[3 * b + 2] = 0.0
    if tangent:
        K[:, :] = 0.0
        C[:, :] = 0.0
        Ks[:, :] = 0.0
    w = np.zeros(6)
    P = np.zeros((2, 6))
    idx = np.zeros(6, dtype=np.int64)
    for k in range(sp_body.shape[0]):
        bi = sp_body[k, 0]
        bj = sp_body[k, 1]
        stiff = sp_geom[k, 4]
        damp = sp_geom[k, 5]
        rest = sp_geom[k, 6]
        length, rate, nx, ny, aix, aiy, ajx, ajy, dvx, dvy = spring_state(q, v, k, sp_body,
                                                                          sp_geom)
        tension = stiff * (length - rest) + damp * rate
        # w = d(length)/d(q_i, q_j)
        w[0] = -nx
        w[1] = -ny
        w[2] = -(aix * ny - aiy * nx)
        w[3] = nx
        w[4] = ny
        w[5] = ajx * ny - ajy * nx
        for a in range(3):
            idx[a] = 3 * bi + a
            idx[3 + a] = 3 * bj + a
        for a in range(6):
            body = bi if a < 3 else bj
            if body >= 0:
                f[idx[a]] -= tension * w[a]
        if tangent:
            # point Jacobians for the geometric stiffness (tension / length) (I - n n^T)
            pair_point_jacobians(P, aix, aiy, ajx, ajy)
            inv_l = 1.0 / length if length > 1e-300 else 0.0
            geo = tension * inv_l
            geo_s = max(stiff * (length - rest), 0.0) * inv_l
            # the damper's rate n.(dv) changes with the direction n: d(rate)/dq = dv_perp P / l
            proj = nx * dvx + ny * dvy
            px = (dvx - proj * nx) * inv_l * damp
            py = (dvy - proj * ny) * inv_l * damp
            for a in range(6):
                ba = bi if a < 3 else bj
                if ba < 0:
                    continue
                for c in range(6):
                    bc = bi if c < 3 else bj
                    if bc < 0:
                        continue
                    pp = transverse_form(P, nx, ny, a, c)
                    K[idx[a], idx[c]] += (stiff * w[a] * w[c] + geo * pp
                                          + w[a] * (px * P[0, c] + py * P[1, c]))
                    Ks[idx[a], idx[c]] += stiff * w[a] * w[c] + geo_s * pp
                    C[idx[a], idx[c]] += damp * w[a] * w[c]


@njit(cache=True)
def total_energy(q, v, mdiag, mass, gvec, sp_body, sp_geom):
    """Kinetic + gravitational + spring energy [J]."""
    e = 0.0
    for i in range(q.shape[0]):
        e += 0.5 * mdiag[i] * v[i] * v[i]
    for b in range(mass.shape[0]):
        e -= mass[b] * (gvec[0] * q[3 * b] + gvec[1] * q[3 * b + 1])
    for k in range(sp_body.shape[0]):
        length = spring_state(q, v, k, sp_body, sp_geom)[0]
        e += 0.5 * sp_geom[k, 4] * (length - sp_geom[k, 6]) ** 2
    return e


# ----------------------------------------------------------------------------------------------
# contact elements
# ----------------------------------------------------------------------------------------------
@njit(cache=True)
def contact_rows(q, k, ct_type, ct_body, ct_geom, wN, wT):
    """Gap ``g_N`` [m] of contact ``k`` and its normal / tangential Jacobian entries.

    ``wN[0:3]``, ``wT[0:3]`` belong to body a (surface), ``wN[3:6]``, ``wT[3:6]`` to body b
    (sphere). Elements (SPEC section 3):

    - plane: n is the plane normal, g = n.(c_b - c_a) - r_b;
    - outside (sphere on sphere): n = (c_b - c_a)/|.|, g = |c_b - c_a| - r_a - r_b;
    - inside (sphere in sphere): n = (c_b - c_a)/|.|, g = r_a - r_b - |c_b - c_a|.

    The tangent is t = e_z x n; the slip is the velocity of the sphere's material point at the
    contact minus that of body a's material point there (taken at the race radius r_a).
    """
    ia = ct_body[k, 0]
    ib = ct_body[k, 1]
    p = ct_geom[k]
    cax, cay, aax, aay = body_point(q, ia, p[0], p[1])
    cbx, cby, abx, aby = body_point(q, ib, p[2], p[3])
    rb = p[5]
    dx = cbx - cax
    dy = cby - cay
    kind = ct_type[k]
    if kind == CONTACT_PLANE:
        ang = p[4]
        if ia >= 0:
            ang += q[3 * ia + 2]
        nx = np.cos(ang)
        ny = np.sin(ang)
        g = nx * dx + ny * dy - rb
        tx = -ny
        ty = nx
        # normal rows: d/dt [n.(c_b - c_a)], n turns with body a
        wN[0] = -nx
        wN[1] = -ny
        wN[2] = -(aax * ny - aay * nx) + (dx * tx + dy * ty)
        wN[3] = nx
        wN[4] = ny
        wN[5] = abx * ny - aby * nx
        # contact point on the sphere and on the plane, relative to the body origins
        rbx = abx - rb * nx
        rby = aby - rb * ny
        rax = aax + dx - (rb + g) * nx
        ray = aay + dy - (rb + g) * ny
    else:
        dist, nx, ny = unit_direction(dx, dy)
        tx = -ny
        ty = nx
        sign = 1.0
        if kind == CONTACT_OUTSIDE:
            g = dist - p[4] - rb
            rbx = abx - rb * nx
            rby = aby - rb * ny
        else:
            g = p[4] - rb - dist
            sign = -1.0
            rbx = abx + rb * nx
            rby = aby + rb * ny
        rax = aax + p[4] * nx
        ray = aay + p[4] * ny
        wN[0] = -sign * nx
        wN[1] = -sign * ny
        wN[2] = -sign * (aax * ny - aay * nx)
        wN[3] = sign * nx
        wN[4] = sign * ny
        wN[5] = sign * (abx * ny - aby * nx)
    wT[0] = -tx
    wT[1] = -ty
    wT[2] = -(rax * ty - ray * tx)
    wT[3] = tx
    wT[4] = ty
    wT[5] = rbx * ty - rby * tx
    return g


@njit(cache=True)
def _scatter_row(row, w, ia, ib):
    """Write the 6 element entries of ``w`` into a dense generalized row."""
    row[:] = 0.0
    if ia >= 0:
        for a in range(3):
            row[3 * ia + a] += w[a]
    if ib >= 0:
        for a in range(3):
            row[3 * ib + a] += w[3 + a]


@njit(cache=True)
def _row_dot(w, ia, ib, x):
    s = 0.0
    if ia >= 0:
        for a in range(3):
            s += w[a] * x[3 * ia + a]
    if ib >= 0:
        for a in range(3):
            s += w[3 + a] * x[3 * ib + a]
    return s


@njit(cache=True)
def contact_hessian(q, k, ct_type, ct_body, ct_geom, H):
    """Second derivative of the gap of contact ``k`` with respect to (q_a, q_b), 6 x 6.

    For the sphere elements g = s |c_b - c_a| + const (s = +1 outside, -1 inside):
    H = s [P^T (I - n n^T) P / L + n . d2(c_b - c_a)]. It is the contact's geometric stiffness
    in the position correction: a pinched ball carries multipliers large enough for it to
    matter against the ball's mass. Left zero for the plane element (exact for a plane on the
    ground and a sphere centred on its body)."""
    H[:, :] = 0.0
    kind = ct_type[k]
    if kind == CONTACT_PLANE:
        return
    ia = ct_body[k, 0]
    ib = ct_body[k, 1]
    p = ct_geom[k]
    cax, cay, aax, aay = body_point(q, ia, p[0], p[1])
    cbx, cby, abx, aby = body_point(q, ib, p[2], p[3])
    dist, nx, ny = unit_direction(cbx - cax, cby - cay)
    if dist <= 1e-300:
        return
    sign = 1.0 if kind == CONTACT_OUTSIDE else -1.0
    P = np.zeros((2, 6))
    pair_point_jacobians(P, aax, aay, abx, aby)
    for a in range(6):
        for c in range(6):
            H[a, c] = sign * transverse_form(P, nx, ny, a, c) / dist
    if ia < 0:
        for a in range(3):
            for c in range(6):
                H[a, c] = 0.0
                H[c, a] = 0.0
    else:
        H[2, 2] += sign * (nx * aax + ny * aay)
    if ib >= 0:
        H[5, 5] -= sign * (nx * abx + ny * aby)


@njit(cache=True)
def contact_velocities(q, v, ct_type, ct_body, ct_geom, gap, vn, vt):
    """Gaps [m], normal and tangential relative velocities [m/s] of every contact."""
    wN = np.zeros(6)
    wT = np.zeros(6)
    for k in range(ct_type.shape[0]):
        gap[k] = contact_rows(q, k, ct_type, ct_body, ct_geom, wN, wT)
        vn[k] = _row_dot(wN, ct_body[k, 0], ct_body[k, 1], v)
        vt[k] = _row_dot(wT, ct_body[k, 0], ct_body[k, 1], v)


# ----------------------------------------------------------------------------------------------
# dense linear algebra on the mass-like matrices
# ----------------------------------------------------------------------------------------------
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


# ----------------------------------------------------------------------------------------------
# generalized-alpha coefficients
# ----------------------------------------------------------------------------------------------
@njit(cache=True)
def alpha_coefficients(rho_inf):
    """(alpha_m, alpha_f, gamma, beta) of generalized-alpha for a spectral radius rho_inf."""
    am = (2.0 * rho_inf - 1.0) / (rho_inf + 1.0)
    af = rho_inf / (rho_inf + 1.0)
    gam = 0.5 + af - am
    beta = 0.25 * (gam + 0.5) ** 2
    return am, af, gam, beta


@njit(cache=True)
def initial_acceleration(q, v, t, mdiag, mass, gvec, sp_body, sp_geom, jt_type, jt_body,
                         jt_geom, vdot, lam):
    """Smooth acceleration at t = 0 from M vdot = f + G^T lam, G vdot + gamma = 0."""
    n = q.shape[0]
    m = joint_row_count(jt_type)
    f = np.zeros(n)
    K = np.zeros((n, n))
    smooth_forces(q, v, mass, gvec, sp_body, sp_geom, f, K, K, K, False)
    g = np.zeros(m)
    G = np.zeros((m, n))
    gam = np.zeros(m)
    dgdt = np.zeros(m)
    bilateral(q, v, t, jt_type, jt_body, jt_geom, g, G, gam, dgdt)
    A = np.zeros((n + m, n + m))
    rhs = np.zeros(n + m)
    for i in range(n):
        A[i, i] = mdiag[i]
        rhs[i] = f[i]
    for r in range(m):
        for i in range(n):
            A[i, n + r] = -G[r, i]
            A[n + r, i] = G[r, i]
        rhs[n + r] = -gam[r]
    x = np.linalg.solve(A, rhs)
    vdot[:] = x[:n]
    lam[:] = x[n:]


# ----------------------------------------------------------------------------------------------
# stage 1: smooth step
# ----------------------------------------------------------------------------------------------
@njit(cache=True)
def smooth_step(q, v, acc, vdot, lam, t1, h, coef, tol, max_iter, mdiag, mass, gvec, sp_body,
                sp_geom, jt_type, jt_body, jt_geom, q_t, v_t, acc1, vdot1, f_t, K_t, C_t, Ks_t):
    """Generalized-alpha prediction with smooth forces and bilateral joints (velocity level).

    Newton on ``vdot1``; fills q_t, v_t, acc1, vdot1, lam and the forces/tangents at (q_t, v_t).
    Returns (iterations, converged).
    """
    am, af, gam, beta = coef
    n = q.shape[0]
    m = lam.shape[0]
    ca = (1.0 - af) / (1.0 - am)
    g = np.zeros(m)
    G = np.zeros((m, n))
    gm = np.zeros(m)
    dgdt = np.zeros(m)
    J = np.zeros((n, n))
    rhs = np.zeros(n + m)
    vdot1[:] = vdot
    iters = 0
    converged = False
    for it in range(max_iter + 1):
        for i in range(n):
            acc1[i] = ((1.0 - af) * vdot1[i] + af * vdot[i] - am * acc[i]) / (1.0 - am)
            q_t[i] = q[i] + h * v[i] + h * h * (0.5 - beta) * acc[i] + h * h * beta * acc1[i]
            v_t[i] = v[i] + h * (1.0 - gam) * acc[i] + h * gam * acc1[i]
        smooth_forces(q_t, v_t, mass, gvec, sp_body, sp_geom, f_t, K_t, C_t, Ks_t, True)
        bilateral(q_t, v_t, t1, jt_type, jt_body, jt_geom, g, G, gm, dgdt)
        scale = 1e-300
        res_f = 0.0
        for i in range(n):
            react = 0.0
            for r in range(m):
                react += G[r, i] * lam[r]
            rhs[i] = -(mdiag[i] * vdot1[i] - f_t[i] - react)
            res_f = max(res_f, abs(rhs[i]))
            scale = max(scale, abs(f_t[i]), abs(mdiag[i] * vdot1[i]), abs(react))
        res_c = 0.0
        for r in range(m):
            c = dgdt[r]
            for i in range(n):
                c += G[r, i] * v_t[i]
            rhs[n + r] = -c
            res_c = max(res_c, abs(c))
        if res_f <= tol * scale and res_c <= tol:
            converged = True
            break
        if it == max_iter:
            break
        iters += 1
        # Newton step on [J, -G^T; c G, 0] by the Schur complement of the joints: J is
        # diagonal but for the bodies joined by springs, so block_inverse keeps it cheap
        for i in range(n):
            for j in range(n):
                J[i, j] = (C_t[i, j] * h * gam + K_t[i, j] * h * h * beta) * ca
            J[i, i] += mdiag[i]
        Jinv = block_inverse(J)
        dv = Jinv @ rhs[:n]
        if m > 0:
            cG = G * (h * gam * ca)
            JG = Jinv @ G.T
            S = cG @ JG
            dlam = np.linalg.solve(S, rhs[n:] - cG @ dv)
            dv += JG @ dlam
            for r in range(m):
                lam[r] += dlam[r]
        for i in range(n):
            vdot1[i] += dv[i]
    return iters, converged


# ----------------------------------------------------------------------------------------------
# stage 2: position correction
# ----------------------------------------------------------------------------------------------
@njit(cache=True)
def _position_residual(q_t, U, nu_b, nu_c, t1, h, mdiag, Ap, jt_type, jt_body, jt_geom,
                       ct_type, ct_body, ct_geom, r_c, gb, Gb, gap, GN, q1):
    """Scaled residual [m] of the position problem at (U, nu): joints, complementarity in the
    augmented-Lagrangian form (nu - max(0, nu - r g))/r, and equilibrium M^-1 (Ap U - G^T nu).
    Also refreshes joint and contact rows at q1 = q_t + U."""
    n = q_t.shape[0]
    for i in range(n):
        q1[i] = q_t[i] + U[i]
    gm = np.zeros(gb.shape[0])
    dgdt = np.zeros(gb.shape[0])
    bilateral(q1, U, t1, jt_type, jt_body, jt_geom, gb, Gb, gm, dgdt)
    wN = np.zeros(6)
    wT = np.zeros(6)
    res = 0.0
    for r in range(gb.shape[0]):
        res = max(res, abs(gb[r]))
    for k in range(ct_type.shape[0]):
        gap[k] = contact_rows(q1, k, ct_type, ct_body, ct_geom, wN, wT)
        _scatter_row(GN[k], wN, ct_body[k, 0], ct_body[k, 1])
        rk = r_c[k]
        val = nu_c[k] - max(0.0, nu_c[k] - rk * gap[k])
        res = max(res, abs(val) / rk)
    eq = Ap @ U - Gb.T @ nu_b - GN.T @ nu_c
    for i in range(n):
        res = max(res, abs(eq[i]) / mdiag[i])
    return res


@njit(cache=True)
def position_step(q_t, t1, h, tol, max_iter, eta, mdiag, Ks_t, jt_type, jt_body, jt_geom,
                  ct_type, ct_body, ct_geom, q1, nu_c, gap):
    """Position correction: M U = G^T nu (with the springs' elastic stiffness h^2 Ks in the
    metric, symmetric positive semi-definite so that the metric stays positive definite),
    joints g(q_t + U) = 0 and 0 <= g_N ⊥ nu_N >= 0 for every contact.

    Semismooth Newton with Delassus-scaled augmentation r_j = 1/(G_j A^-1 G_j^T), a proximal
    term (eta/r)(nu - nu_k) on active rows for redundant (pinched) contacts, and a backtracking
    line search on the scaled residual. Returns (iterations, converged)."""
    n = q_t.shape[0]
    nbil = joint_row_count(jt_type)
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
    res = _position_residual(q_t, U, nu_b, nu_c, t1, h, mdiag, Ap, jt_type, jt_body, jt_geom,
                             ct_type, ct_body, ct_geom, r_c, gb, Gb, gap, GN, q1)
    for k in range(nc):
        dkk = GN[k] @ (Ainv @ GN[k])
        r_c[k] = 1.0 / dkk if dkk > 0.0 else 1.0
    res = _position_residual(q_t, U, nu_b, nu_c, t1, h, mdiag, Ap, jt_type, jt_body, jt_geom,
                             ct_type, ct_body, ct_geom, r_c, gb, Gb, gap, GN, q1)
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
                    contact_hessian(q1, k, ct_type, ct_body, ct_geom, Hloc)
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
            res_try = _position_residual(q_t, U_try, nub_try, nuc_try, t1, h, mdiag, Ap,
                                         jt_type, jt_body, jt_geom, ct_type, ct_body, ct_geom,
                                         r_c, gb_try, Gb_try, gap_try, GN_try, q_try)
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
        res = _position_residual(q_t, U, nu_b, nu_c, t1, h, mdiag, Ap, jt_type, jt_body,
                                 jt_geom, ct_type, ct_body, ct_geom, r_c, gb, Gb, gap, GN, q1)
        converged = res <= target
    return iters, converged


# ----------------------------------------------------------------------------------------------
# stage 3: velocity jump with Newton's impact law and Coulomb friction
# ----------------------------------------------------------------------------------------------
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
def velocity_step(q1, q_t, v_t, t1, h, tol, max_iter, eta, gap_close, mdiag, mass, gvec,
                  sp_body, sp_geom, jt_type, jt_body, jt_geom, ct_type, ct_body, ct_geom,
                  ct_law, f_t, nu_c, gap, vn_minus, vt_minus, v1, lamN, lamT, lam_b):
    """Velocity jump W = v1 - v_t with impulses Lambda on the joints and on the contacts closed
    after the position correction (nu_N > 0 or g_N <= gap_close). ``lamN``/``lamT`` hold the
    previous step's impulses (warm start) on entry. Returns (iterations, converged)."""
    n = q1.shape[0]
    nbil = joint_row_count(jt_type)
    nc = ct_type.shape[0]
    f1 = np.zeros(n)
    K1 = np.zeros((n, n))
    C1 = np.zeros((n, n))
    smooth_forces(q1, v_t, mass, gvec, sp_body, sp_geom, f1, K1, C1, np.zeros((n, n)), True)
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
    bilateral(q1, v_t, t1, jt_type, jt_body, jt_geom, gb, Gb, gm, dgdt)
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
        contact_rows(q1, k, ct_type, ct_body, ct_geom, wN, wT)
        _scatter_row(G[row], wN, ct_body[k, 0], ct_body[k, 1])
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
            _scatter_row(G[row], wT, ct_body[k, 0], ct_body[k, 1])
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


# ----------------------------------------------------------------------------------------------
# the time loop
# ----------------------------------------------------------------------------------------------
@njit(cache=True)
def integrate_chunk(k0, k1, h, rho_inf, tol, max_iter, eta, drive_row,
                    mdiag, mass, gvec, jt_type, jt_body, jt_geom, sp_body, sp_geom,
                    ct_type, ct_body, ct_geom, ct_law,
                    q, v, acc, vdot, lam_s, lam_b, lamN_prev, lamT_prev, vn_prev, vt_prev,
                    out_q, out_v, out_lamN, out_lamT, out_nu, out_gap, out_vn_pre, out_vn_post,
                    out_vn_free, out_energy, out_iter, out_conv, out_torque):
    """Advance steps k0 .. k1-1 (state at time k0*h on entry, at k1*h on exit), writing the
    outputs of each step at index k+1. The state arrays are updated in place.

    ``out_vn_free`` receives the normal relative velocity just before the jump of the step,
    G_N(q_{n+1}) v~_{n+1}: the smooth-step velocity seen by the contact rows at the corrected
    position [m/s].

    Returns the index of the first step whose sub-problems did not all converge, or -1."""
    n = q.shape[0]
    nc = ct_type.shape[0]
    coef = alpha_coefficients(rho_inf)
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
    first_bad = -1
    for k in range(k0, k1):
        t1 = (k + 1) * h
        it_s, ok_s = smooth_step(q, v, acc, vdot, lam_s, t1, h, coef, tol, max_iter, mdiag,
                                 mass, gvec, sp_body, sp_geom, jt_type, jt_body, jt_geom,
                                 q_t, v_t, acc1, vdot1, f_t, K_t, C_t, Ks_t)
        it_p, ok_p = position_step(q_t, t1, h, tol, max_iter, eta, mdiag, Ks_t, jt_type,
                                   jt_body, jt_geom, ct_type, ct_body, ct_geom, q1, nu_c, gap)
        contact_velocities(q1, v_t, ct_type, ct_body, ct_geom, gap_free, vn_free, vt_free)
        it_v, ok_v = velocity_step(q1, q_t, v_t, t1, h, tol, max_iter, eta, gap_close, mdiag,
                                   mass, gvec, sp_body, sp_geom, jt_type, jt_body, jt_geom,
                                   ct_type, ct_body, ct_geom, ct_law, f_t, nu_c, gap,
                                   vn_prev, vt_prev, v1, lamN_prev, lamT_prev, lam_b)
        # accept the step
        for i in range(n):
            q[i] = q1[i]
            v[i] = v1[i]
            acc[i] = acc1[i]
            vdot[i] = vdot1[i]
        contact_velocities(q, v, ct_type, ct_body, ct_geom, gap, vn, vt)
        out_q[k + 1] = q
        out_v[k + 1] = v
        for j in range(nc):
            out_lamN[k + 1, j] = lamN_prev[j]
            out_lamT[k + 1, j] = lamT_prev[j]
            out_nu[k + 1, j] = nu_c[j]
            out_gap[k + 1, j] = gap[j]
            out_vn_pre[k + 1, j] = vn_prev[j]
            out_vn_post[k + 1, j] = vn[j]
            out_vn_free[k + 1, j] = vn_free[j]
            vn_prev[j] = vn[j]
            vt_prev[j] = vt[j]
        out_energy[k + 1] = total_energy(q, v, mdiag, mass, gvec, sp_body, sp_geom)
        out_iter[k + 1, STAGE_SMOOTH] = it_s
        out_iter[k + 1, STAGE_POSITION] = it_p
        out_iter[k + 1, STAGE_VELOCITY] = it_v
        ok = ok_s and ok_p and ok_v
        out_conv[k + 1] = 1 if ok else 0
        if drive_row >= 0:
            out_torque[k + 1] = lam_s[drive_row] + lam_b[drive_row] / h
        if not ok and first_bad < 0:
            first_bad = k
    return first_bad
