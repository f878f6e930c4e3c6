"""Smooth forces: gravity and linear spring-dampers between body points (the cage), with
their exact tangents, and the mechanical energy they store."""

from __future__ import annotations

import numpy as np

from .bodies import (
    body_omega,
    clear_pair_blocks,
    pair_point_jacobians,
    point_pair_row,
    store6,
    transverse_form,
    unit_direction,
)
from .contact import element_points, pair_indices
from .jit import entry_step_kernel, inline_kernel, kernel, step_kernel

#: ``tangent`` flags of :func:`smooth_forces_into`. NumPy booleans, not Python ones: Numba types
#: a Python constant argument as a literal and compiles a specialisation per value.
WITH_TANGENTS = np.bool_(True)
FORCES_ONLY = np.bool_(False)


@inline_kernel
def spring_state(q, v, k, sp_body, sp_geom):
    """Length [m], its rate [m/s], unit direction and lever arms of spring ``k``."""
    bi = sp_body[k, 0]
    bj = sp_body[k, 1]
    xi, yi, aix, aiy, xj, yj, ajx, ajy = element_points(q, k, sp_body, sp_geom)
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


@inline_kernel
def spring_row(q, v, k, sp_body, sp_geom, w, idx):
    """:func:`spring_state` of spring ``k``, with its row w = d(length)/d(q_i, q_j) (6) and
    the global indices of those coordinates (:func:`~.contact.pair_indices`) into ``w`` and
    ``idx``."""
    state = spring_state(q, v, k, sp_body, sp_geom)
    _, _, nx, ny, aix, aiy, ajx, ajy, _, _ = state
    store6(w, point_pair_row(nx, ny, aix, aiy, ajx, ajy, 1.0))
    pair_indices(idx, sp_body[k, 0], sp_body[k, 1])
    return state


@kernel
def smooth_forces(q, v, ma, f, K, C, Ks, tangent):
    """:func:`smooth_forces_into` with work arrays of its own."""
    smooth_forces_into(q, v, ma, f, K, C, Ks, tangent, np.empty((3, 6)),
                       np.empty((2, 6), dtype=np.int64))


@step_kernel
def smooth_forces_into(q, v, ma, f, K, C, Ks, tangent, fw, iw):
    """Gravity plus spring-damper forces ``f`` [N, N m]; with ``tangent`` also the stiffness
    ``K = -df/dq`` and damping ``C = -df/dv`` matrices. K is exact for springs between body
    origins (the cage); for off-centre points the lever arms' second derivative is left out
    (Newton stays convergent, only its rate changes). ``Ks`` receives the symmetric positive
    semi-definite elastic part (axial stiffness and the geometric term of a tensile spring): it
    is the metric of the position correction, which must stay positive definite.

    The tangents are written in the blocks of the springs' body pairs only (cleared first,
    :func:`~.bodies.clear_pair_blocks`): elsewhere K, C and Ks keep what they held, zero in
    every caller. ``fw`` (3 x 6) and ``iw`` (2 x 6, integers): work rows (made once per run by
    the time loops, so that a step allocates nothing here)."""
    mass = ma.mass
    gvec = ma.gvec
    sp_body = ma.sp_body
    sp_geom = ma.sp_geom
    nb = mass.shape[0]
    for b in range(nb):
        f[3 * b] = mass[b] * gvec[0]
        f[3 * b + 1] = mass[b] * gvec[1]
        f[3 * b + 2] = 0.0
    if tangent:
        clear_pair_blocks(K, sp_body)
        clear_pair_blocks(C, sp_body)
        clear_pair_blocks(Ks, sp_body)
    w = fw[0]
    Px = fw[1]
    Py = fw[2]
    idx = iw[0]
    loc = iw[1]
    for k in range(sp_body.shape[0]):
        bi = sp_body[k, 0]
        bj = sp_body[k, 1]
        stiff = sp_geom[k, 4]
        damp = sp_geom[k, 5]
        rest = sp_geom[k, 6]
        length, rate, nx, ny, aix, aiy, ajx, ajy, dvx, dvy = spring_row(q, v, k, sp_body,
                                                                        sp_geom, w, idx)
        tension = stiff * (length - rest) + damp * rate
        for a in range(6):
            body = bi if a < 3 else bj
            if body >= 0:
                f[idx[a]] -= tension * w[a]
        if tangent:
            # point Jacobians for the geometric stiffness (tension / length) (I - n n^T)
            px_t, py_t = pair_point_jacobians(aix, aiy, ajx, ajy)
            store6(Px, px_t)
            store6(Py, py_t)
            inv_l = 1.0 / length if length > 1e-300 else 0.0
            geo = tension * inv_l
            geo_s = max(stiff * (length - rest), 0.0) * inv_l
            # the damper's rate n.(dv) changes with the direction n: d(rate)/dq = dv_perp P / l
            proj = nx * dvx + ny * dvy
            px = (dvx - proj * nx) * inv_l * damp
            py = (dvy - proj * ny) * inv_l * damp
            # the local coordinates the spring's point pair moves with (a spring between ball
            # centres has no lever arms: its rotations drop out, 4 x 4 entries instead of 6 x 6)
            m = 0
            for a in range(6):
                if (bi if a < 3 else bj) >= 0 and (w[a] != 0.0 or Px[a] != 0.0
                                                    or Py[a] != 0.0):
                    loc[m] = a
                    m += 1
            for ia in range(m):
                a = loc[ia]
                for ic in range(m):
                    c = loc[ic]
                    pp = transverse_form(Px[a], Py[a], Px[c], Py[c], nx, ny)
                    K[idx[a], idx[c]] += (stiff * w[a] * w[c] + geo * pp
                                          + w[a] * (px * Px[c] + py * Py[c]))
                    Ks[idx[a], idx[c]] += stiff * w[a] * w[c] + geo_s * pp
                    C[idx[a], idx[c]] += damp * w[a] * w[c]


@kernel
def spring_damping(q, v, ma, C):
    """:func:`spring_damping_into` with work arrays of its own."""
    spring_damping_into(q, v, ma, C, np.empty((3, 6)), np.empty((2, 6), dtype=np.int64))


@step_kernel
def spring_damping_into(q, v, ma, C, fw, iw):
    """The damping matrix C = -df/dv of the spring-dampers alone (what the velocity jump
    needs of the smooth forces' tangents; :func:`smooth_forces` with ``tangent`` also fills
    the stiffness matrices). Written in the springs' blocks only, as :func:`smooth_forces`
    does; ``fw``, ``iw``: work rows as there."""
    sp_body = ma.sp_body
    sp_geom = ma.sp_geom
    clear_pair_blocks(C, sp_body)
    w = fw[0]
    idx = iw[0]
    for k in range(sp_body.shape[0]):
        bi = sp_body[k, 0]
        bj = sp_body[k, 1]
        damp = sp_geom[k, 5]
        spring_row(q, v, k, sp_body, sp_geom, w, idx)
        for a in range(6):
            if (bi if a < 3 else bj) < 0:
                continue
            for c in range(6):
                if (bi if c < 3 else bj) < 0:
                    continue
                C[idx[a], idx[c]] += damp * w[a] * w[c]


@inline_kernel
def _less_gravity(e, q, ma):
    """``e`` [J] less the gravitational potential energy of the bodies at q, body by body (one
    loop for :func:`total_energy` and :func:`gravity_energy`, so that both round alike)."""
    mass = ma.mass
    gvec = ma.gvec
    for b in range(mass.shape[0]):
        e -= mass[b] * (gvec[0] * q[3 * b] + gvec[1] * q[3 * b + 1])
    return e


@entry_step_kernel
def total_energy(q, v, ma):
    """Kinetic + gravitational + spring energy [J]."""
    mdiag = ma.mdiag
    sp_body = ma.sp_body
    sp_geom = ma.sp_geom
    e = 0.0
    for i in range(q.shape[0]):
        e += 0.5 * mdiag[i] * v[i] * v[i]
    e = _less_gravity(e, q, ma)
    for k in range(sp_body.shape[0]):
        length = spring_state(q, v, k, sp_body, sp_geom)[0]
        e += 0.5 * sp_geom[k, 4] * (length - sp_geom[k, 6]) ** 2
    return e


@step_kernel
def gravity_energy(q, ma):
    """Gravitational potential energy of the bodies at q [J], datum at the origin (the part of
    :func:`total_energy` whose datum is arbitrary)."""
    return _less_gravity(0.0, q, ma)


@step_kernel
def energy_scale_term(energy, q, ma):
    """What one state adds to the energy audit's scale [J]: the larger of |E| and E without
    gravity's potential (kinetic, spring and contact energy, which have no datum), so that a
    run whose E stays near 0 by the choice of datum (a mechanism falling from rest) is measured
    against its kinetic energy. NaN when ``energy`` is NaN."""
    e = abs(energy)
    free = energy - gravity_energy(q, ma)
    if free > e:
        e = free
    return e


@entry_step_kernel
def energy_scale_terms_into(energy, q, ma, row0, row1, terms):
    """:func:`energy_scale_term` of rows ``row0 .. row1-1`` of ``energy`` [J] and ``q`` into
    ``terms[0 .. row1-row0-1]`` (the energy audit's, from Python: the same operations as the
    time loop's, so the same scale)."""
    for i in range(row0, row1):
        terms[i - row0] = energy_scale_term(energy[i], q[i], ma)
