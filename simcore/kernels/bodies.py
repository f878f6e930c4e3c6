"""Planar rigid bodies: world points of body-fixed points, angular velocities, and the
two-point Jacobian helpers that joints, springs and contact elements share.

Conventions: ``q``, ``v`` hold 3 entries per body, (x [m], y [m], phi [rad]) and
(vx [m/s], vy [m/s], omega [rad/s]); body index -1 is the ground, whose "local" points are world
points. An element between bodies a and b has 3 + 3 Jacobian entries (``w[0:3]`` for a,
``w[3:6]`` for b); :func:`scatter_row` and :func:`row_dot` map them to generalized rows, and
:func:`pair_support` lists the (at most six) generalized columns such a row can occupy, so that
the step's products with constraint rows visit those columns only.
"""

from __future__ import annotations

import numpy as np

from .jit import entry_step_kernel, step_kernel


@entry_step_kernel
def body_point(q, body, px, py):
    """World position (x, y) and lever arm (ax, ay) = R(phi) p of a body-fixed point [m]."""
    if body < 0:
        return px, py, 0.0, 0.0
    if px == 0.0 and py == 0.0:
        # the body's reference point (a ball's centre): no rotation to evaluate
        return q[3 * body], q[3 * body + 1], 0.0, 0.0
    phi = q[3 * body + 2]
    c = np.cos(phi)
    s = np.sin(phi)
    ax = c * px - s * py
    ay = s * px + c * py
    return q[3 * body] + ax, q[3 * body + 1] + ay, ax, ay


@step_kernel
def body_point_cached(q, body, px, py, trig):
    """:func:`body_point` with a cache of each body's (phi, cos phi, sin phi) in ``trig``
    (nb x 3, made by :func:`trig_cache`), reused while the body's angle is the same number: a
    contact element's surface point turns with its race, and the sixteen contacts of the
    bearing share two races, so that one configuration needs two sine/cosine pairs instead of
    one per contact. The same numbers as :func:`body_point` (the same cos and sin of the same
    angle); ``trig = None`` is :func:`body_point` itself."""
    if trig is None:
        return body_point(q, body, px, py)
    if body < 0:
        return px, py, 0.0, 0.0
    if px == 0.0 and py == 0.0:
        return q[3 * body], q[3 * body + 1], 0.0, 0.0
    phi = q[3 * body + 2]
    if trig[body, 0] == phi:  # (a NaN angle never matches: computed afresh)
        c = trig[body, 1]
        s = trig[body, 2]
    else:
        c = np.cos(phi)
        s = np.sin(phi)
        trig[body, 0] = phi
        trig[body, 1] = c
        trig[body, 2] = s
    ax = c * px - s * py
    ay = s * px + c * py
    return q[3 * body] + ax, q[3 * body + 1] + ay, ax, ay


def trig_cache(nb):
    """The cache of :func:`body_point_cached` for nb bodies (NaN angles: nothing cached)."""
    return np.full((nb, 3), np.nan)


@step_kernel
def body_omega(v, body):
    """Angular velocity of a body [rad/s] (0 for the ground)."""
    if body < 0:
        return 0.0
    return v[3 * body + 2]


@step_kernel
def unit_direction(dx, dy):
    """Length of (dx, dy) and its unit vector ((1, 0) for a zero vector)."""
    length = np.sqrt(dx * dx + dy * dy)
    if length > 1e-300:
        return length, dx / length, dy / length
    return length, 1.0, 0.0


@step_kernel
def pair_point_jacobians(aix, aiy, ajx, ajy):
    """The two rows (x, y) of P = d(c_j - c_i)/d(q_i, q_j) (2 x 6) for body points with lever
    arms a_i, a_j, as two 6-tuples (no array is allocated in the step)."""
    return ((-1.0, 0.0, aiy, 1.0, 0.0, -ajy),
            (0.0, -1.0, -aix, 0.0, 1.0, ajx))


@step_kernel
def point_pair_row(ux, uy, aix, aiy, ajx, ajy, sign):
    """sign * d[u.(c_j - c_i)]/d(q_i, q_j) (a 6-tuple) for a fixed direction u and body points
    with lever arms a_i, a_j: the row of a spring's length, of a contact's normal or tangent."""
    return (-sign * ux, -sign * uy, -sign * (aix * uy - aiy * ux),
            sign * ux, sign * uy, sign * (ajx * uy - ajy * ux))


@step_kernel
def store6(w, t):
    """w[:6] = the 6-tuple t (tuples are cheap to build, but slow to index by a loop variable:
    loops read arrays)."""
    for a in range(6):
        w[a] = t[a]


@step_kernel
def transverse_form(px_a, py_a, px_c, py_c, nx, ny):
    """Entry (a, c) of P^T (I - n n^T) P from columns a and c of P (:func:`pair_point_jacobians`):
    the change of direction of a two-point distance."""
    return (px_a * ((1.0 - nx * nx) * px_c - nx * ny * py_c)
            + py_a * (-nx * ny * px_c + (1.0 - ny * ny) * py_c))


@step_kernel
def scatter_row(row, w, ia, ib):
    """Write the 6 element entries of ``w`` into a dense generalized row."""
    row[:] = 0.0
    if ia >= 0:
        for a in range(3):
            row[3 * ia + a] += w[a]
    if ib >= 0:
        for a in range(3):
            row[3 * ib + a] += w[3 + a]


@step_kernel
def row_dot(w, ia, ib, x):
    s = 0.0
    if ia >= 0:
        for a in range(3):
            s += w[a] * x[3 * ia + a]
    if ib >= 0:
        for a in range(3):
            s += w[3 + a] * x[3 * ib + a]
    return s


@step_kernel
def pair_support(ia, ib, cols, r):
    """Write into ``cols[r]`` the generalized columns of a row between bodies ia and ib (three
    per body that is not the ground, -1) and return their count. (Rows of work arrays are
    addressed by index throughout: a row view costs two atomic reference-count updates.)"""
    m = 0
    if ia >= 0:
        for a in range(3):
            cols[r, m] = 3 * ia + a
            m += 1
    if ib >= 0 and ib != ia:
        for a in range(3):
            cols[r, m] = 3 * ib + a
            m += 1
    return m


@step_kernel
def place_row(G, r, w, ia, ib):
    """Write the 6 element entries of ``w`` into row r of G, whose other entries are known to
    be zero (:func:`scatter_row` without clearing the row first)."""
    if ia >= 0:
        for a in range(3):
            G[r, 3 * ia + a] = w[a]
    if ib >= 0:
        for a in range(3):
            G[r, 3 * ib + a] = w[3 + a]


@step_kernel
def support_dot(G, r, cols, c, m, x):
    """G[r] . x over the columns ``cols[c, :m]`` (the row's support, :func:`pair_support`)."""
    s = 0.0
    for t in range(m):
        i = cols[c, t]
        s += G[r, i] * x[i]
    return s


#: Operations of :func:`fill_pair_blocks`. NumPy integers, not Python ones: Numba types a
#: Python constant argument as a literal and compiles a specialisation per value.
BLOCKS_CLEAR = np.int64(0)
BLOCKS_SCALE = np.int64(1)
BLOCKS_NEWTON = np.int64(2)


@step_kernel
def fill_pair_blocks(dst, A, B, x, y, z, w, pair_body, op):
    """Write the entries of the n x n matrix ``dst`` that couple the two bodies of each pair
    (``pair_body`` (m, 2), -1 the ground), diagonal blocks included: all that an element between
    those bodies writes, so that a tangent matrix costs what its elements cost, not n^2.

    ``op``: :data:`BLOCKS_CLEAR` dst = 0; :data:`BLOCKS_SCALE` dst = x A; :data:`BLOCKS_NEWTON`
    dst = (A x y + B x x z) w (the smooth stage's Newton matrix from C = A and K = B, with
    x = h, y = gamma, z = beta, w = (1 - alpha_f)/(1 - alpha_m)). The rest of ``dst`` is left as
    it is."""
    for k in range(pair_body.shape[0]):
        for s in range(2):
            ba = pair_body[k, s]
            if ba < 0:
                continue
            for t in range(2):
                bc = pair_body[k, t]
                if bc < 0:
                    continue
                for a in range(3):
                    i = 3 * ba + a
                    for c in range(3):
                        j = 3 * bc + c
                        if op == BLOCKS_CLEAR:
                            dst[i, j] = 0.0
                        elif op == BLOCKS_SCALE:
                            dst[i, j] = x * A[i, j]
                        else:
                            dst[i, j] = (A[i, j] * x * y + B[i, j] * x * x * z) * w


@step_kernel
def clear_pair_blocks(A, pair_body):
    """Zero the body-pair blocks of A (:func:`fill_pair_blocks`)."""
    fill_pair_blocks(A, A, A, 0.0, 0.0, 0.0, 0.0, pair_body, BLOCKS_CLEAR)


@step_kernel
def scale_pair_blocks(dst, src, alpha, pair_body):
    """dst = alpha * src on the body-pair blocks (:func:`fill_pair_blocks`), for a ``src`` that
    is zero elsewhere; the rest of ``dst`` is left as it is."""
    fill_pair_blocks(dst, src, src, alpha, 0.0, 0.0, 0.0, pair_body, BLOCKS_SCALE)
