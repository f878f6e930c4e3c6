"""Bundles of arrays handed to the kernels (Numba accepts namedtuples of arrays and scalars).

One :class:`ModelArrays` replaces the thirty-odd positional arrays of the model; the time loop
also takes its settings, its state and its outputs as one bundle each.
"""

from __future__ import annotations

from collections import namedtuple

#: The model as flat arrays (built by :meth:`simcore.model.Model.arrays`).
#:
#: - ``mdiag`` (3 nb): diagonal mass matrix (m, m, Izz) per body [kg, kg m^2]
#: - ``mass`` (nb): body masses [kg]; ``gvec`` (2): gravity [m/s^2]
#: - ``jt_type`` (nj), ``jt_body`` (nj, 2), ``jt_geom`` (nj, 6): joints
#: - ``sp_body`` (ns, 2), ``sp_geom`` (ns, 7): spring-dampers (points, k [N/m], c [N s/m], rest [m])
#: - ``ct_type`` (nc), ``ct_body`` (nc, 2), ``ct_geom`` (nc, 6): contact elements
#: - ``ct_law`` (nc, 3): (mu, e_N, e_T) of each contact
#: - ``ct_hertz`` (nc, 2): (K [N m^-1.5], chi [-]) of the compliant law of each contact
ModelArrays = namedtuple("ModelArrays", [
    "mdiag", "mass", "gvec", "jt_type", "jt_body", "jt_geom", "sp_body", "sp_geom",
    "ct_type", "ct_body", "ct_geom", "ct_law", "ct_hertz"])

#: Scalars of the step: h [s], rho_inf, tol, max_iter, eta (proximal), drive_row (-1: none),
#: and for the compliant model t0 (start time [s]), v_reg (friction regularisation [m/s]) and
#: v_pre_min (floor of the onset approach speed in the damping term [m/s]).
StepSettings = namedtuple("StepSettings", ["h", "rho_inf", "tol", "max_iter", "eta",
                                           "drive_row", "t0", "v_reg", "v_pre_min"])

#: State carried from step to step (updated in place): q, v, the generalized-alpha
#: accelerations acc and vdot, the joint multipliers of the smooth stage lam_s and of the
#: velocity jump lam_b, the contact impulses lamN, lamT (warm start) and the contact velocities
#: vn, vt at the end of the last step.
StepState = namedtuple("StepState", ["q", "v", "acc", "vdot", "lam_s", "lam_b", "lamN", "lamT",
                                     "vn", "vt"])

#: State of the compliant contacts (per contact, updated in place): v_pre (approach speed at
#: the onset [m/s]), closed (1 while the contact is closed), the last step's forces FN, FT [N],
#: gap [m], vn, vt [m/s], and the accumulators of the current output interval: FN_max, FT_at_max
#: [N], LN, LT [N s], gap_min [m], vn_start [m/s]; it_max (3) and ok (1) of the interval.
CompliantState = namedtuple("CompliantState", [
    "v_pre", "closed", "FN", "FT", "gap", "vn", "vt", "FN_max", "FT_at_max", "LN", "LT",
    "gap_min", "vn_start", "it_max", "ok"])

#: Outputs of the compliant time loop, one row per output sample (row 0: t0).
CompliantOutputs = namedtuple("CompliantOutputs", [
    "q", "v", "F_N", "F_T", "Lambda_N", "Lambda_T", "gap_N", "vn_pre", "vn_post", "energy",
    "iterations", "converged", "drive_torque"])

#: Per-step outputs (row k + 1 written by step k), see :class:`simcore.model.Trajectory`;
#: ``halvings`` (int8): the times the step was halved (0: taken whole).
ChunkOutputs = namedtuple("ChunkOutputs", [
    "q", "v", "lambda_N", "lambda_T", "nu_N", "gap_N", "vn_pre", "vn_post", "vn_free",
    "energy", "iterations", "converged", "drive_torque", "halvings"])
