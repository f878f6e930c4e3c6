"""One run of the crank-slider from a validated configuration: build, integrate, wrap."""

from __future__ import annotations

from .config import output_every, validate_config
from .limits import check_run
from .mechanism import crank_slider
from .model import SolverError  # noqa: F401  (re-exported)


def run(config: dict, progress: bool = False):
    """Simulate the crank-slider bearing of ``config`` and return its dataset (SPEC section 5).

    Parameters
    ----------
    config : dict
        A configuration (validated here again, defaults filled).
    progress : bool
        Show a progress bar on stderr when it is a terminal.

    Returns
    -------
    xarray.Dataset

    Raises
    ------
    simcore.ConfigError
        On bad input, before any work.
    simcore.ConfigError
        Also for a step size that cannot resolve the model (``solver.on_unresolved_dt``) and for
        a run whose arrays would exceed ``solver.max_memory_gb``: checked after building the
        model, before any array of the time loop is allocated (:mod:`simcore.limits`).
    simcore.SolverError
        When a step does not converge, or creates energy (:mod:`simcore.audit`), and
        ``solver.on_nonconvergence`` is ``"error"``.
    """
    from .io import trajectory_dataset

    cfg = validate_config(config)
    solver = cfg["solver"]
    model, layout = crank_slider(cfg["model"])
    m = cfg["model"]
    check_run(cfg, model)
    traj = model.simulate(solver["dt"], solver["t_end"], rho_inf=solver["rho_inf"],
                          tol=solver["tol"], max_iter=solver["max_iter"],
                          proximal=solver["proximal"],
                          on_nonconvergence=solver["on_nonconvergence"], progress=progress,
                          contact_model=m["contact_model"], damping_law=m["damping_law"],
                          friction_regularization=m["friction_regularization"],
                          output_every=output_every(cfg),
                          energy_tol=solver["energy_tol"])
    return trajectory_dataset(traj, model, layout, cfg)
