"""Numba kernels of the simulation, one module per piece of physics.

- :mod:`.bodies`: body points, angular velocities and the two-point Jacobian helpers;
- :mod:`.joints`: bilateral joints; :mod:`.springs`: gravity, spring-dampers, energy;
- :mod:`.contact`: contact element geometry (gap, normal, Jacobian rows, Hessian, velocities),
  shared by both contact models;
- :mod:`.linalg`: small dense algebra; :mod:`.generalized_alpha`: coefficients, initial
  acceleration and the smooth stage shared by both models;
- :mod:`.position_correction`, :mod:`.velocity_jump`: the nonsmooth model's position
  correction and velocity jump; :mod:`.nonsmooth_step`: its time loop (with the retries of a
  failed step);
- :mod:`.hertz`: the compliant contact law (Hertz force with hysteresis damping, regularised
  Coulomb friction) with exact tangents; :mod:`.compliant_step`: joint projection and the time
  loop of the compliant model with output sampling; :mod:`.compliant_adaptive`: its loop with
  adaptive steps.

The model is handed over as one :class:`~.bundles.ModelArrays` (a namedtuple of arrays).
Numba's cache is keyed by a hash of these sources (:mod:`simcore.startup.numba_cache`) before any of
them is imported, so an edit in one module cannot leave stale code of another in the cache.
"""

from ..startup.numba_cache import configure_cache

CACHE_DIR = configure_cache()

from .bodies import (  # noqa: E402
    body_omega,
    body_point,
    clear_pair_blocks,
    fill_pair_blocks,
    pair_point_jacobians,
    pair_support,
    place_row,
    point_pair_row,
    row_dot,
    scale_pair_blocks,
    scatter_row,
    store6,
    support_dot,
    transverse_form,
    unit_direction,
)
from .bundles import (  # noqa: E402
    AdaptiveSettings,
    AdaptiveState,
    ChunkOutputs,
    CompliantOutputs,
    CompliantState,
    ModelArrays,
    StepSettings,
    StepState,
)
from .compliant_adaptive import (  # noqa: E402
    ACCEPTED,
    BELOW_DT_MIN,
    REJECTED_ERROR,
    REJECTED_NEWTON,
    REJECTED_ONSET,
    integrate_compliant_adaptive,
)
from .compliant_step import (  # noqa: E402
    compliant_work,
    integrate_compliant_chunk,
    project_joints,
)
from .contact import (  # noqa: E402
    CONTACT_INSIDE,
    CONTACT_OUTSIDE,
    CONTACT_PLANE,
    contact_hessian,
    contact_rows,
    contact_velocities,
    contact_velocities_into,
)
from .generalized_alpha import (  # noqa: E402
    alpha_coefficients,
    initial_acceleration,
    smooth_step,
    smooth_work,
)
from .hertz import (  # noqa: E402
    FN_ROW,
    FT_ROW,
    contact_forces,
    contact_records,
    elastic_energy,
    normal_force,
)
from .joints import (  # noqa: E402
    JOINT_ANGLE,
    JOINT_PRISMATIC,
    JOINT_REVOLUTE,
    bilateral,
    joint_row_count,
    joint_support,
)
from .linalg import block_factor_work  # noqa: E402
from .nonsmooth_step import (  # noqa: E402
    RETRY_VELOCITY_ITERATIONS,
    STAGE_POSITION,
    STAGE_SMOOTH,
    STAGE_VELOCITY,
    RetrySettings,
    integrate_chunk,
    loop_stage_calls,
    nonsmooth_work,
    position_step,
    solve_velocity_problem,
    velocity_step,
)
from .springs import (  # noqa: E402
    energy_scale_terms_into,
    smooth_forces,
    spring_damping,
    spring_state,
    total_energy,
)

__all__ = [
    "CACHE_DIR", "CONTACT_INSIDE", "CONTACT_OUTSIDE", "CONTACT_PLANE", "JOINT_ANGLE",
    "JOINT_PRISMATIC", "JOINT_REVOLUTE", "RETRY_VELOCITY_ITERATIONS",
    "STAGE_POSITION",
    "STAGE_SMOOTH", "STAGE_VELOCITY",
    "ChunkOutputs", "CompliantOutputs", "CompliantState", "ModelArrays", "RetrySettings",
    "StepSettings",
    "StepState", "alpha_coefficients", "loop_stage_calls",
    "bilateral", "block_factor_work", "joint_support", "pair_support", "place_row",
    "scale_pair_blocks", "store6",
    "support_dot",
    "body_omega", "body_point", "clear_pair_blocks", "fill_pair_blocks", "contact_hessian",
    "contact_rows",
    "contact_velocities", "contact_velocities_into", "initial_acceleration", "smooth_work",
    "integrate_chunk", "joint_row_count",
    "nonsmooth_work",
    "pair_point_jacobians", "point_pair_row", "position_step", "row_dot", "scatter_row",
    "smooth_forces", "spring_damping",
    "smooth_step", "solve_velocity_problem", "spring_state", "total_energy",
    "energy_scale_terms_into", "transverse_form",
    "unit_direction", "velocity_step", "contact_forces", "elastic_energy", "normal_force",
    "compliant_work", "integrate_compliant_chunk", "project_joints", "AdaptiveSettings",
    "AdaptiveState", "integrate_compliant_adaptive", "ACCEPTED", "BELOW_DT_MIN",
    "REJECTED_ERROR", "REJECTED_NEWTON", "REJECTED_ONSET", "contact_records", "FN_ROW",
    "FT_ROW",
]
