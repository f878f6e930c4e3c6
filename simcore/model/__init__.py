"""Model building: the planar multibody builder, the time-loop driver, the energy audit and the
scenes built with them (the crank-slider bearing and the validation cases).

- :mod:`.builder`: :class:`Model` (bodies, joints, spring-dampers, contacts) and the flat
  arrays it hands to :mod:`simcore.kernels`;
- :mod:`.driver`: :class:`SolverSettings` and the time loop's driver in named stages;
- :mod:`.audit`: the energy audit of a run; :mod:`.hertz`: the Hertz stiffness and the
  hysteresis damping law;
- :mod:`.bearing`: the bearing's geometry (radii, pitch circle, lands);
- :mod:`.integrity`: the invariants of a bearing checked on every step;
- :mod:`.mechanism`: the crank-slider with its ball bearing, and the validation scenes.
"""

from .builder import (
    CONTACT_KINDS,
    CONTACT_MODELS,
    DAMPING_LAWS,
    Model,
    damping_factor,
    hertz_stiffness,
)
from .driver import ReleaseStop, SolverError, SolverSettings, Trajectory

__all__ = ["CONTACT_KINDS", "CONTACT_MODELS", "DAMPING_LAWS", "Model", "ReleaseStop", "SolverError",
           "SolverSettings", "Trajectory", "damping_factor", "hertz_stiffness"]
