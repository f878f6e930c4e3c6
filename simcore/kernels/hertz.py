"""Compliant (Hertz) contact law on the shared contact elements of :mod:`.contact`.

Normal force F = K delta^(3/2) (1 + chi delta_dot / v_pre), F >= 0, with delta = -g_N the
indentation, K the Hertz stiffness of the element and chi the damping factor of the chosen law
(Flores, Hunt-Crossley, Lankarani-Nikravesh; see :func:`simcore.model.damping_factor`); v_pre
is the approach speed at the onset of the contact (a per-contact state of the time loop).
Friction is Coulomb's, regularised below the slip speed v_reg: F_T = -mu F sat(v_T / v_reg),
sat(x) = clip(x, -1, 1).

The generalized force of a contact is F wN + F_T wT (wN, wT: the element's Jacobian rows), so a
positive F opens the gap. Tangents K = -df/dq, C = -df/dv are exact for the normal force
(stiffness, damping and the geometric term F d2g/dq2 of the sphere elements). For friction the
tangent is exact (mu F / v_reg inside the regularisation band |v_T| < v_reg, 0 outside), and
the turning of the tangent row with q is left out (a term of size mu F / L).

``ma.ct_hertz[k]`` holds (K [N m^-1.5], chi [-]) of contact k.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from .bodies import row_dot
from .contact import (
    contact_gap_cached,
    contact_hessian_into,
    contact_rows_cached,
    pair_indices,
)
from .jit import entry_kernel, inline_kernel, kernel, step_kernel

#: Work arrays of :func:`contact_forces_into` and :func:`elastic_energy_into` (made once per
#: run by :func:`hertz_work`): a contact's Jacobian rows wN, wT, its gap Hessian H (6 x 6),
#: local velocities, H v, dF/dq, the global indices of its six coordinates and the Hessian's
#: own work rows P (2 x 6, :func:`~.contact.contact_hessian_into`).
HertzWork = namedtuple("HertzWork", ["wN", "wT", "H", "loc", "Hv", "dFdq", "idx", "P"])


def hertz_work():
    """The work arrays of :func:`contact_forces_into` (:data:`HertzWork`)."""
    return HertzWork(np.zeros(6), np.zeros(6), np.zeros((6, 6)), np.zeros(6), np.zeros(6),
                     np.zeros(6), np.zeros(6, dtype=np.int64), np.zeros((2, 6)))


#: The compliant law's inputs beyond the model arrays: ``v_pre`` (nc) each contact's approach
#: speed at its onset [m/s] (the damping term's), ``v_reg`` the friction regularisation [m/s].
ContactLaw = namedtuple("ContactLaw", ["v_pre", "v_reg"])

#: Rows of the per-contact records (:func:`contact_records`, one column per contact) that
#: :func:`contact_forces_into` and :func:`open_contact_velocities_into` fill: the normal
#: force FN [N], the friction force FT [N], the gap [m], the normal and tangential relative
#: velocities vn, vt [m/s], and from ``WT_ROW`` on the six tangential Jacobian entries.
FN_ROW = 0
FT_ROW = 1
GAP_ROW = 2
VN_ROW = 3
VT_ROW = 4
WT_ROW = 5
RECORD_ROWS = WT_ROW + 6


def contact_records(nc):
    """Records of nc contacts (RECORD_ROWS x nc, see :data:`FN_ROW`), made in Python."""
    return np.zeros((RECORD_ROWS, nc))


#: an undamped Hertz impact lasts this many times its largest indentation over its approach speed
HERTZ_TIME = 2.94


@step_kernel
def hertz_impact_time(inv_mass, K, speed):
    """Duration [s] of an undamped Hertz impact at approach speed ``speed`` [m/s] of a body of
    inverse effective mass ``inv_mass`` [1/kg] on a contact of stiffness ``K`` [N m^-1.5]:
    2.94 delta_max / v with delta_max = (5 m v^2 / (4 K))^(2/5). (Python code calls its
    ``py_func``: the stability limits and the zoom's step take it from here too.)"""
    delta_max = (1.25 * speed * speed / (inv_mass * K)) ** 0.4
    return HERTZ_TIME * delta_max / speed


@kernel
def normal_force(delta, delta_dot, K, chi, v_pre):
    """Hertz force with hysteresis damping and its partial derivatives.

    Returns (F [N], dF/d(delta) [N/m], dF/d(delta_dot) [N s/m]); all zero where the contact is
    open (delta <= 0) or the damping term would pull (F < 0)."""
    if delta <= 0.0:
        return 0.0, 0.0, 0.0
    root = np.sqrt(delta)
    elastic = K * delta * root
    damp = 1.0 + chi * delta_dot / v_pre
    F = elastic * damp
    if F <= 0.0:
        return 0.0, 0.0, 0.0
    return F, 1.5 * K * root * damp, elastic * chi / v_pre


@entry_kernel
def contact_forces(q, v, ma, v_pre, v_reg, f, K, C, tangent, rec):
    """Add the compliant contact forces to ``f`` [N, N m] and, with ``tangent``, their
    stiffness ``K`` and damping ``C`` to the matrices (in place): :func:`contact_forces_into`
    and :func:`open_contact_velocities_into` with work arrays of their own (for calls outside
    the time loop), so that the records ``rec`` (:func:`contact_records`) are filled for
    every contact. ``v_pre`` (nc): onset speeds [m/s]; ``v_reg``: friction regularisation
    [m/s]."""
    hw = HertzWork(np.zeros(6), np.zeros(6), np.zeros((6, 6)), np.zeros(6), np.zeros(6),
                   np.zeros(6), np.zeros(6, dtype=np.int64), np.zeros((2, 6)))
    contact_forces_into(q, v, ma, ContactLaw(v_pre, v_reg), f, K, C, tangent, rec, hw, None,
                        np.zeros(ma.ct_type.shape[0], dtype=np.bool_))
    open_contact_velocities_into(q, v, ma, rec, hw, None)


@step_kernel
def open_contact_velocities_into(q, v, ma, rec, hw, trig):
    """The gaps [m], normal and tangential relative velocities [m/s] and the tangential
    Jacobian entries of the open contacts (``rec[GAP_ROW]`` >= 0 on entry) in their records
    ``rec`` (:func:`contact_records`), which :func:`contact_forces_into` leaves out or skips:
    the time loop needs them once a step, at its end, not at every Newton iterate. ``trig``:
    see :func:`~.contact.contact_rows_cached`.
    """
    wN = hw.wN
    wT = hw.wT
    gap = rec[GAP_ROW]
    for k in range(ma.ct_type.shape[0]):
        if gap[k] < 0.0:
            continue
        ia = ma.ct_body[k, 0]
        ib = ma.ct_body[k, 1]
        gap[k] = contact_rows_cached(q, k, ma.ct_type, ma.ct_body, ma.ct_geom, wN, wT, trig)
        rec[VN_ROW, k] = row_dot(wN, ia, ib, v)
        rec[VT_ROW, k] = row_dot(wT, ia, ib, v)
        for a in range(6):
            rec[WT_ROW + a, k] = wT[a]


@step_kernel
def contact_forces_into(q, v, ma, law, f, K, C, tangent, rec, hw, trig, skip):
    """Add the compliant contact forces to ``f`` [N, N m] and, with ``tangent``, their
    stiffness ``K`` and damping ``C`` to the matrices (in place). Fills each contact's record
    in ``rec`` (:func:`contact_records`): normal force [N], friction force [N] (along
    t = e_z x n) and gap [m]; for the closed contacts (gap < 0) also the normal and
    tangential relative velocities [m/s] and the tangential Jacobian entries
    (:func:`open_contact_velocities_into` adds those of the open ones: an open contact costs
    its gap alone here). ``law``: :data:`ContactLaw` (onset speeds, friction regularisation).
    The friction slope is the exact one: mu F / v_reg inside the band |v_T| < v_reg, 0
    outside (see :func:`~.compliant_step.compliant_smooth_step` for how Newton copes with
    the kink). ``hw``: work arrays (:func:`hertz_work`); ``trig``: the bodies' sines and
    cosines (:func:`~.bodies.body_point_cached`, or None). A contact with ``skip`` set is
    known to be open (see :func:`~.compliant_step.compliant_smooth_step`): no force, its gap
    left as it is."""
    wN = hw.wN
    wT = hw.wT
    idx = hw.idx
    for k in range(ma.ct_type.shape[0]):
        if skip[k]:
            rec[FN_ROW, k] = 0.0
            rec[FT_ROW, k] = 0.0
            continue
        g = contact_gap_cached(q, k, ma.ct_type, ma.ct_body, ma.ct_geom, trig)
        rec[GAP_ROW, k] = g
        if g >= 0.0:  # open: no force (normal_force of delta = -g <= 0)
            rec[FN_ROW, k] = 0.0
            rec[FT_ROW, k] = 0.0
            continue
        ia = ma.ct_body[k, 0]
        ib = ma.ct_body[k, 1]
        contact_rows_cached(q, k, ma.ct_type, ma.ct_body, ma.ct_geom, wN, wT, trig)
        vN = row_dot(wN, ia, ib, v)
        vT = row_dot(wT, ia, ib, v)
        rec[VN_ROW, k] = vN
        rec[VT_ROW, k] = vT
        F, dF_dd, dF_ddot = normal_force(-g, -vN, ma.ct_hertz[k, 0], ma.ct_hertz[k, 1],
                                         law.v_pre[k])
        mu = ma.ct_law[k, 0]
        x = vT / law.v_reg
        sat = min(max(x, -1.0), 1.0)
        Ft = -mu * F * sat
        rec[FN_ROW, k] = F
        rec[FT_ROW, k] = Ft
        for a in range(6):
            rec[WT_ROW + a, k] = wT[a]
        if F == 0.0:
            continue
        pair_indices(idx, ia, ib)
        for a in range(6):
            body = ia if a < 3 else ib
            if body >= 0:
                f[idx[a]] += F * wN[a] + Ft * wT[a]
        if tangent:
            dsat = 1.0 / law.v_reg if abs(x) < 1.0 else 0.0
            _add_contact_tangents(q, v, k, ma, hw, K, C, (F, dF_dd, dF_ddot, mu, sat, dsat))


@inline_kernel
def _add_contact_tangents(q, v, k, ma, hw, K, C, terms):
    """Add the stiffness ``K`` = -df/dq and damping ``C`` = -df/dv of closed contact ``k``
    (its rows and coordinate indices in ``hw``, from :func:`contact_forces_into`) to the
    matrices. ``terms``: its normal force F [N] with dF/d(delta) [N/m] and dF/d(delta_dot)
    [N s/m] (:func:`normal_force`), the friction coefficient mu [-], sat(v_T / v_reg) [-] and
    its slope in v_T [s/m]."""
    F, dF_dd, dF_ddot, mu, sat, dsat = terms
    wN = hw.wN
    wT = hw.wT
    H = hw.H
    loc = hw.loc
    Hv = hw.Hv
    dFdq = hw.dFdq
    idx = hw.idx
    ia = ma.ct_body[k, 0]
    ib = ma.ct_body[k, 1]
    # local velocities and H v (H = d2 g / dq2 of the element)
    contact_hessian_into(q, k, ma, H, hw.P)
    for a in range(6):
        body = ia if a < 3 else ib
        loc[a] = v[idx[a]] if body >= 0 else 0.0
    for a in range(6):
        s = 0.0
        for c in range(6):
            s += H[a, c] * loc[c]
        Hv[a] = s
    # dF/dq = -dF/d(delta) wN - dF/d(delta_dot) H v ;  dF/dv = -dF/d(delta_dot) wN
    for a in range(6):
        dFdq[a] = -dF_dd * wN[a] - dF_ddot * Hv[a]
    for a in range(6):
        ba = ia if a < 3 else ib
        if ba < 0:
            continue
        for c in range(6):
            bc = ia if c < 3 else ib
            if bc < 0:
                continue
            # normal: f = F wN ; friction: f = Ft wT, Ft = -mu F sat(vT / v_reg)
            kk = -(wN[a] * dFdq[c] + F * H[a, c]) + mu * sat * wT[a] * dFdq[c]
            cc = (dF_ddot * wN[a] * wN[c] - mu * sat * wT[a] * dF_ddot * wN[c]
                  + mu * F * dsat * wT[a] * wT[c])
            K[idx[a], idx[c]] += kk
            C[idx[a], idx[c]] += cc


@entry_kernel
def elastic_energy(q, ma):
    """Energy stored in the compliant contacts, sum of (2/5) K delta^(5/2) [J]."""
    return elastic_energy_into(q, ma, None)


@step_kernel
def elastic_energy_into(q, ma, trig):
    """:func:`elastic_energy` with the bodies' sines and cosines cached in ``trig``
    (:func:`~.bodies.body_point_cached`, or None)."""
    e = 0.0
    for k in range(ma.ct_type.shape[0]):
        delta = -contact_gap_cached(q, k, ma.ct_type, ma.ct_body, ma.ct_geom, trig)
        if delta > 0.0:
            e += 0.4 * ma.ct_hertz[k, 0] * delta * delta * np.sqrt(delta)
    return e
