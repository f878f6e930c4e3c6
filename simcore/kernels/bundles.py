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
ModelArrays = namedtuple("ModelArrays", [
    "mdiag", "mass", "gvec", "jt_type", "jt_body", "jt_geom", "sp_body", "sp_geom",
    "ct_type", "ct_body", "ct_geom", "ct_law"])

#: Scalars of the step: h [s], rho_inf, tol, max_iter, eta (proximal), drive_row (-1: none).
StepSettings = namedtuple("StepSettings", ["h", "rho_inf", "tol", "max_iter", "eta",
                                           "drive_row"])

#: State carried from step to step (updated in place): q, v, the generalized-alpha
#: accelerations acc and vdot, the joint multipliers of the smooth stage lam_s and of the
#: velocity jump lam_b, the contact impulses lamN, lamT (warm start) and the contact velocities
#: vn, vt at the end of the last step.
StepState = namedtuple("StepState", ["q", "v", "acc", "vdot", "lam_s", "lam_b", "lamN", "lamT",
                                     "vn", "vt"])

#: Per-step outputs (row k + 1 written by step k), see :class:`simcore.model.Trajectory`.
ChunkOutputs = namedtuple("ChunkOutputs", [
    "q", "v", "lambda_N", "lambda_T", "nu_N", "gap_N", "vn_pre", "vn_post", "vn_free",
    "energy", "iterations", "converged", "drive_torque"])
