"""Bilateral joints: revolute, prismatic (with locked rotation) and the prescribed rotation
(rheonomic drive)."""

from __future__ import annotations

import numpy as np

from .bodies import body_omega, body_point_cached, pair_support
from .jit import step_kernel

JOINT_REVOLUTE = 0
JOINT_PRISMATIC = 1
JOINT_ANGLE = 2



@step_kernel
def joint_row_count(jt_type):
    """Number of constraint rows of each joint and in total."""
    n = 0
    for j in range(jt_type.shape[0]):
        n += 1 if jt_type[j] == JOINT_ANGLE else 2
    return n


@step_kernel
def joint_support(jt_type, jt_body, cols, ncols):
    """Support of every joint row (the columns of its bodies, :func:`~.bodies.pair_support`):
    ``cols[r, :ncols[r]]`` for the rows in the order :func:`bilateral` writes them."""
    row = np.int64(0)  # not a literal 0, which would compile a second specialisation
    for j in range(jt_type.shape[0]):
        m = pair_support(jt_body[j, 0], jt_body[j, 1], cols, row)
        ncols[row] = m
        if jt_type[j] != JOINT_ANGLE:
            for a in range(m):
                cols[row + 1, a] = cols[row, a]
            ncols[row + 1] = m
            row += 2
        else:
            row += 1


@step_kernel
def bilateral(q, v, t, ma, g, G, gamma, dgdt):
    """Evaluate all bilateral constraints.

    Fills ``g`` (position residual [m or rad]), ``G`` (rows x ndof Jacobian), ``gamma``
    (the velocity-squared term of the acceleration constraint, G a + gamma = 0) and ``dgdt``
    (explicit time derivative, rheonomic joints) in place. ``ma``: :class:`ModelArrays`.
    Only the entries of each row on its joint's bodies' columns are written: G must be zero
    elsewhere on entry (as made by ``np.zeros``).
    """
    bilateral_cached(q, v, t, ma, g, G, gamma, dgdt, None)


@step_kernel
def bilateral_cached(q, v, t, ma, g, G, gamma, dgdt, trig):
    """:func:`bilateral` with the bodies' sines and cosines cached in ``trig``
    (:func:`~.bodies.body_point_cached`; None: no cache)."""
    jt_type = ma.jt_type
    jt_body = ma.jt_body
    jt_geom = ma.jt_geom
    row = 0
    for j in range(jt_type.shape[0]):
        bi = jt_body[j, 0]
        bj = jt_body[j, 1]
        # clear the joint's rows on its bodies' columns, the only entries written (not all of
        # G, which is evaluated at every iterate of a compliant step)
        for r in range(row, row + (1 if jt_type[j] == JOINT_ANGLE else 2)):
            for b in (bi, bj):
                if b >= 0:
                    G[r, 3 * b] = 0.0
                    G[r, 3 * b + 1] = 0.0
                    G[r, 3 * b + 2] = 0.0
        # scalars, not a row view (a view costs two atomic reference-count updates)
        p0, p1, p2 = jt_geom[j, 0], jt_geom[j, 1], jt_geom[j, 2]
        p3, p4, p5 = jt_geom[j, 3], jt_geom[j, 4], jt_geom[j, 5]
        kind = jt_type[j]
        if kind == JOINT_REVOLUTE:
            xi, yi, aix, aiy = body_point_cached(q, bi, p0, p1, trig)
            xj, yj, ajx, ajy = body_point_cached(q, bj, p2, p3, trig)
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
            # body bi slides along the ground axis through (p2, p3) at angle p4;
            # its rotation is locked at p5
            xi, yi, aix, aiy = body_point_cached(q, bi, p0, p1, trig)
            nx = -np.sin(p4)
            ny = np.cos(p4)
            wi = body_omega(v, bi)
            g[row] = nx * (xi - p2) + ny * (yi - p3)
            g[row + 1] = q[3 * bi + 2] - p5
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
            # prescribed rotation phi = p0 + p1 t (rheonomic)
            g[row] = q[3 * bi + 2] - p0 - p1 * t
            gamma[row] = 0.0
            dgdt[row] = -p1
            G[row, 3 * bi + 2] = 1.0
            row += 1
