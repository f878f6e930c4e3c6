"""Contact element geometry shared by the nonsmooth and the compliant contact models: gap,
normal and tangential Jacobian rows, the gap's Hessian and the contact velocities.

A contact pairs a surface body ``a`` (plane, race) with a sphere on body ``b`` (ball). Its gap
``g_N`` is positive when open; its rows ``wN``/``wT`` hold the 3 + 3 Jacobian entries of bodies
a and b, so that ``dg_N/dt = wN . (v_a, v_b)`` and the tangential slip is ``wT . (v_a, v_b)``
with ``t = e_z x n`` and ``n`` the element's normal.
"""

from __future__ import annotations

import numpy as np

from .bodies import (
    body_point,
    body_point_cached,
    pair_point_jacobians,
    point_pair_row,
    row_dot,
    store6,
    transverse_form,
    unit_direction,
)
from .jit import entry_kernel, entry_step_kernel, inline_kernel, kernel, step_kernel

CONTACT_PLANE = 0
CONTACT_OUTSIDE = 1
CONTACT_INSIDE = 2


@inline_kernel
def element_points(q, k, el_body, el_geom):
    """World positions and lever arms of the two body points of a two-body element ``k``
    (a contact or a spring: ``el_body`` (., 2) its bodies, -1 the ground; ``el_geom[k, :4]``
    the points in their bodies' frames [m]): (xa, ya, ax_a, ay_a, xb, yb, ax_b, ay_b)
    (:func:`~.bodies.body_point`)."""
    # scalars, not a row view (a view costs two atomic reference-count updates)
    p0, p1, p2, p3 = el_geom[k, 0], el_geom[k, 1], el_geom[k, 2], el_geom[k, 3]
    xa, ya, aax, aay = body_point(q, el_body[k, 0], p0, p1)
    xb, yb, abx, aby = body_point(q, el_body[k, 1], p2, p3)
    return xa, ya, aax, aay, xb, yb, abx, aby


@inline_kernel
def pair_indices(idx, ia, ib):
    """The global indices of the 3 + 3 coordinates of bodies ``ia``, ``ib`` into ``idx`` (6
    integers; a ground body, -1, gets indices its callers skip)."""
    for a in range(3):
        idx[a] = 3 * ia + a
        idx[3 + a] = 3 * ib + a



@step_kernel
def _plane_normal(q, ia, angle):
    """Unit normal of a plane at ``angle`` [rad] in body ia's frame (-1: the ground)."""
    if ia >= 0:
        angle += q[3 * ia + 2]
    return np.cos(angle), np.sin(angle)


@step_kernel
def _sphere_gap(kind, dist, ra, rb):
    """Gap [m] of a sphere element whose centres are ``dist`` apart: outside (convex)
    dist - r_a - r_b, inside (a sphere in a ring) r_a - r_b - dist."""
    if kind == CONTACT_OUTSIDE:
        return dist - ra - rb
    return ra - rb - dist


@step_kernel
def contact_gap_cached(q, k, ct_type, ct_body, ct_geom, trig):
    """Gap ``g_N`` [m] of contact ``k`` alone: the number :func:`contact_rows_cached` returns,
    to the bit (the same operations), without its Jacobian rows. An open contact of the
    compliant model needs no more while a step iterates."""
    ia = ct_body[k, 0]
    ib = ct_body[k, 1]
    cax, cay, _, _ = body_point_cached(q, ia, ct_geom[k, 0], ct_geom[k, 1], trig)
    cbx, cby, _, _ = body_point_cached(q, ib, ct_geom[k, 2], ct_geom[k, 3], trig)
    dx = cbx - cax
    dy = cby - cay
    kind = ct_type[k]
    if kind == CONTACT_PLANE:
        nx, ny = _plane_normal(q, ia, ct_geom[k, 4])
        return nx * dx + ny * dy - ct_geom[k, 5]
    dist = np.sqrt(dx * dx + dy * dy)  # (the length unit_direction computes)
    return _sphere_gap(kind, dist, ct_geom[k, 4], ct_geom[k, 5])


@step_kernel
def contact_rows(q, k, ct_type, ct_body, ct_geom, wN, wT):
    """:func:`contact_rows_cached` without a cache of the bodies' sines and cosines."""
    return contact_rows_cached(q, k, ct_type, ct_body, ct_geom, wN, wT, None)


@step_kernel
def contact_rows_cached(q, k, ct_type, ct_body, ct_geom, wN, wT, trig):
    """Gap ``g_N`` [m] of contact ``k`` and its normal / tangential Jacobian entries.

    ``wN[0:3]``, ``wT[0:3]`` belong to body a (surface), ``wN[3:6]``, ``wT[3:6]`` to body b
    (sphere). Elements (docs/model.md):

    - plane: n is the plane normal, g = n.(c_b - c_a) - r_b;
    - outside (sphere on sphere): n = (c_b - c_a)/|.|, g = |c_b - c_a| - r_a - r_b;
    - inside (sphere in sphere): n = (c_b - c_a)/|.|, g = r_a - r_b - |c_b - c_a|.

    The tangent is t = e_z x n; the slip is the velocity of the sphere's material point at the
    contact minus that of body a's material point there (taken at the race radius r_a).
    ``trig``: the bodies' sines and cosines (:func:`~.bodies.body_point_cached`) or None.
    """
    ia = ct_body[k, 0]
    ib = ct_body[k, 1]
    # scalars, not a row view (a view costs two atomic reference-count updates)
    p0, p1, p2 = ct_geom[k, 0], ct_geom[k, 1], ct_geom[k, 2]
    p3, p4, p5 = ct_geom[k, 3], ct_geom[k, 4], ct_geom[k, 5]
    cax, cay, aax, aay = body_point_cached(q, ia, p0, p1, trig)
    cbx, cby, abx, aby = body_point_cached(q, ib, p2, p3, trig)
    rb = p5
    dx = cbx - cax
    dy = cby - cay
    kind = ct_type[k]
    if kind == CONTACT_PLANE:
        nx, ny = _plane_normal(q, ia, p4)
        g = nx * dx + ny * dy - rb
        tx = -ny
        ty = nx
        # normal rows: d/dt [n.(c_b - c_a)], n turns with body a
        store6(wN, point_pair_row(nx, ny, aax, aay, abx, aby, 1.0))
        wN[2] += dx * tx + dy * ty
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
        g = _sphere_gap(kind, dist, p4, rb)
        if kind == CONTACT_OUTSIDE:
            rbx = abx - rb * nx
            rby = aby - rb * ny
        else:
            sign = -1.0
            rbx = abx + rb * nx
            rby = aby + rb * ny
        rax = aax + p4 * nx
        ray = aay + p4 * ny
        store6(wN, point_pair_row(nx, ny, aax, aay, abx, aby, sign))
    store6(wT, point_pair_row(tx, ty, rax, ray, rbx, rby, 1.0))
    return g


@kernel
def contact_hessian(q, k, ma, H):
    """:func:`contact_hessian_into` with a work array of its own."""
    contact_hessian_into(q, k, ma, H, np.empty((2, 6)))


@step_kernel
def contact_hessian_into(q, k, ma, H, P):
    """Second derivative of the gap of contact ``k`` with respect to (q_a, q_b), 6 x 6.

    For the sphere elements g = s |c_b - c_a| + const (s = +1 outside, -1 inside):
    H = s [P^T (I - n n^T) P / L + n . d2(c_b - c_a)]. It is the contact's geometric stiffness
    in the position correction: a pinched ball carries multipliers large enough for it to
    matter against the ball's mass. Left zero for the plane element (exact for a plane on the
    ground and a sphere centred on its body). ``P`` (2 x 6): work rows."""
    ct_type = ma.ct_type
    ct_body = ma.ct_body
    H[:, :] = 0.0
    kind = ct_type[k]
    if kind == CONTACT_PLANE:
        return
    ia = ct_body[k, 0]
    ib = ct_body[k, 1]
    cax, cay, aax, aay, cbx, cby, abx, aby = element_points(q, k, ct_body, ma.ct_geom)
    dist, nx, ny = unit_direction(cbx - cax, cby - cay)
    if dist <= 1e-300:
        return
    sign = 1.0 if kind == CONTACT_OUTSIDE else -1.0
    Px = P[0]
    Py = P[1]
    px_t, py_t = pair_point_jacobians(aax, aay, abx, aby)
    store6(Px, px_t)
    store6(Py, py_t)
    for a in range(6):
        for c in range(6):
            H[a, c] = sign * transverse_form(Px[a], Py[a], Px[c], Py[c], nx, ny) / dist
    if ia < 0:
        for a in range(3):
            for c in range(6):
                H[a, c] = 0.0
                H[c, a] = 0.0
    else:
        H[2, 2] += sign * (nx * aax + ny * aay)
    if ib >= 0:
        H[5, 5] -= sign * (nx * abx + ny * aby)


@entry_kernel
def contact_velocities(q, v, ma, gap, vn, vt):
    """Gaps [m], normal and tangential relative velocities [m/s] of every contact."""
    contact_velocities_into(q, v, ma, gap, vn, vt, np.zeros(6), np.zeros(6), None)


@entry_step_kernel
def contact_velocities_into(q, v, ma, gap, vn, vt, wN, wT, trig):
    """:func:`contact_velocities` on work rows ``wN``, ``wT`` (6 entries each) and with the
    bodies' sines and cosines cached in ``trig`` (:func:`~.bodies.body_point_cached`, or
    None)."""
    ct_type = ma.ct_type
    ct_body = ma.ct_body
    for k in range(ct_type.shape[0]):
        gap[k] = contact_rows_cached(q, k, ma.ct_type, ma.ct_body, ma.ct_geom, wN, wT, trig)
        vn[k] = row_dot(wN, ct_body[k, 0], ct_body[k, 1], v)
        vt[k] = row_dot(wT, ct_body[k, 0], ct_body[k, 1], v)
