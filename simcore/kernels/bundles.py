"""Bundles of arrays handed to the kernels (Numba accepts namedtuples of arrays and scalars).

One :class:`ModelArrays` replaces the thirty-odd positional arrays of the model; the time loop
also takes its settings, its state and its outputs as one bundle each.
"""

from __future__ import annotations

from collections import namedtuple

#: The sub-problems of a step, in the order of the columns of its iteration counts (a run's
#: ``iterations``, coordinate ``stage`` of its file): the smooth stage, the position
#: correction, the velocity jump (a compliant step: its smooth and projection stages).
STAGES = ("smooth", "position", "velocity")
STAGE_SMOOTH, STAGE_POSITION, STAGE_VELOCITY = range(3)

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
#: v_pre_min (floor of the onset approach speed in the damping term [m/s]);
#: newton_after_fallback (1 in a retried step's velocity jump, 0 otherwise:
#: :func:`~.velocity_jump.solve_velocity_problem`).
StepSettings = namedtuple("StepSettings", ["h", "rho_inf", "tol", "max_iter", "eta",
                                           "drive_row", "t0", "v_reg", "v_pre_min",
                                           "newton_after_fallback"], defaults=(0,))

#: State carried from step to step (updated in place): q, v, the generalized-alpha
#: accelerations acc and vdot, the joint multipliers of the smooth stage lam_s and of the
#: velocity jump lam_b, the contact impulses lamN, lamT (warm start) and the contact velocities
#: vn, vt at the end of the last step.
StepState = namedtuple("StepState", ["q", "v", "acc", "vdot", "lam_s", "lam_b", "lamN", "lamT",
                                     "vn", "vt"])

#: State of the compliant contacts (per contact, updated in place): v_pre (approach speed at
#: the onset [m/s]), closed (1 while the contact is closed), the last step's forces FN, FT [N],
#: gap [m], vn, vt [m/s], and the accumulators of the current output interval: FN_max, FT_at_max
#: [N], LN, LT [N s], gap_min [m], vn_start [m/s]; it_max (3) and ok (1) of the interval, and
#: the drive's torque impulse over it, drive_impulse (1) [N m s].
CompliantState = namedtuple("CompliantState", [
    "v_pre", "closed", "FN", "FT", "gap", "vn", "vt", "FN_max", "FT_at_max", "LN", "LT",
    "gap_min", "vn_start", "it_max", "ok", "drive_impulse"])

#: Outputs of the compliant time loop, one row per output sample (row 0: t0); drive_torque is
#: the drive's torque averaged over the interval that ends at the row (its torque impulse over
#: the interval's length, whatever the steps in it: the energy audit's drive work); halvings
#: the most halvings of a fixed step retried in the interval (0: none).
CompliantOutputs = namedtuple("CompliantOutputs", [
    "q", "v", "F_N", "F_T", "Lambda_N", "Lambda_T", "gap_N", "vn_pre", "vn_post", "energy",
    "iterations", "converged", "drive_torque", "halvings"])

#: Settings of the compliant loop with adaptive steps (the largest step is StepSettings.h):
#: ``out_dt`` the output interval [s], ``dt_min`` the smallest step the error control may ask
#: for [s], ``err_tol`` the local error tolerance of a step [m], ``onset_steps`` the steps per
#: Hertz contact time of the step in which a contact closes [-], ``keep_growth`` the largest
#: growth the estimate may allow while a step keeps its planned size [-].
AdaptiveSettings = namedtuple("AdaptiveSettings", ["out_dt", "dt_min", "err_tol",
                                                   "onset_steps", "keep_growth"])

#: State and records of the adaptive loop (updated in place): ``h`` (2) the next step's size
#: and the last accepted step's [s]; ``counts`` (5) accepted steps, steps rejected by the error
#: estimate, by a contact's onset, by a smooth stage that did not converge, and steps that
#: needed less than dt_min (taken at dt_min and flagged); ``h_min`` (1) the smallest step
#: taken [s]; ``t_flag`` (1) the end time of the first step taken below its need [s] (-1:
#: none); ``weight`` (n) the error weight of each coordinate (1 for a position, the body's
#: radius of gyration [m] for its angle); ``row_steps`` (rows) the steps taken in each output
#: interval (what a step taken again starts from is the compliant work's ``retry``).
AdaptiveState = namedtuple("AdaptiveState", ["h", "counts", "h_min", "t_flag", "weight",
                                             "row_steps"])

#: Per-step outputs (row k + 1 written by step k), see :class:`simcore.model.Trajectory`;
#: ``halvings`` (int8): the times the step was halved (0: taken whole).
ChunkOutputs = namedtuple("ChunkOutputs", [
    "q", "v", "lambda_N", "lambda_T", "nu_N", "gap_N", "vn_pre", "vn_post", "vn_free",
    "energy", "iterations", "converged", "drive_torque", "halvings"])
