"""analysis: the impulse filter, Flores peak forces, impact tables and figures.

docs/forces.md.

Public API
----------
split_impulses(lam, zero_tol, floor=1e-12, scale=None) -> (lam_fi, lam_s, lam_fisuv)
split_dataset(run_ds, zero_tol=1e-4, zero_floor=1e-12) -> xarray.Dataset
zero_threshold(lam=None, zero_tol=1e-4, floor=1e-12, scale=None) -> float [N s]
hertz_stiffness(r1, r2, E1, nu1, E2, nu2, concave=False) -> K [N/m^1.5]
peak_force(impulse, v_pre, e_N, K, F_static=0.0, h=None, details=False) -> F_max [N]
extract_impacts(run_ds, zero_tol=1e-4, zero_floor=1e-12, r_eff="concave", v_min=1e-3,
                groove_conformity=None, contact_long_ratio=10.0)
top_forces(impacts_ds, n=3, race="outer", events=None)
loaded_stretches(run_ds, impacts_ds) -> an event number per row (a persistent contact: one)
series_stiffness(K1, K2) -> K of two Hertz contacts in series [N/m^1.5]
contact_stress(F, ball_radius, race_radius, race, E, nu, conformity=None) -> a, b, delta, p_max
analysis.dt_check.dt_check(run_ds, t_check=None, tol=0.1, n=6) (rerun at dt/2 and compare)
analysis.zoom.add_zoom_forces(run_ds, impacts_ds, zoom_top=5, ...) (compliant zooms, flag
    method_disagrees)
analysis.episodes.contact_episodes(run_ds) (a compliant run's table)
analysis.summary.point_numbers(run_ds, impacts_ds, settings) / summarize(runs, tables, ...)
    (the study's summary over its axes and both contact models)
analysis.run_life.compliant_life(run_ds, settle_time, settings) (L10, L10r of a compliant run)
analysis.figures.plot_run / plot_study / plot_life (imported lazily: matplotlib is only loaded
    there)
"""

# (first: it sets the kernels' cache folder before any submodule defines one)
from . import _cache  # noqa: F401
from .contact_stress import contact_stress, elliptical_contact, hertz_circular
from .filtering import impact_masks, split_dataset, split_impulses, zero_threshold
from .forces import (
    PeakForce,
    closed_form_elastic,
    effective_radius,
    flores_damping,
    hertz_stiffness,
    peak_force,
)
from .impacts import (
    FLAG,
    KIND,
    RACE,
    extract_impacts,
    loaded_stretches,
    run_geometry,
    series_stiffness,
    top_forces,
)

__all__ = [
    "split_impulses",
    "split_dataset",
    "zero_threshold",
    "impact_masks",
    "hertz_stiffness",
    "effective_radius",
    "flores_damping",
    "closed_form_elastic",
    "peak_force",
    "PeakForce",
    "extract_impacts",
    "run_geometry",
    "top_forces",
    "loaded_stretches",
    "series_stiffness",
    "contact_stress",
    "elliptical_contact",
    "hertz_circular",
    "KIND",
    "RACE",
    "FLAG",
]
