"""Rolling-contact fatigue life and static capacity of the bearing from simulated loads: the
ISO 281 rating (ball and roller bearings), Lundberg–Palmgren per-ball life, ISO/TS 16281's
reference rating life from the element loads (ball and roller bearings, clearance and preload
included), the static load distribution, and the ISO 76 static safety. Pure, float64, and safe under `jax.jit`, `jax.vmap` and
`jax.grad` (``log`` of a life is a smooth objective, e.g. against the clearance).

Two levels:

- **Ratings** from the geometry: ISO 281's `dynamic_load_rating` (balls) and
  `roller_dynamic_load_rating` (rollers) with their tables (`load_rating_factor`,
  `roller_load_rating_factor`), ISO 76's `static_load_rating` and `roller_static_load_rating`
  (`static_load_factor`), and of a bearing's parameters `dynamic_rating`, `static_rating`,
  and ISO/TS 16281's raceway ratings `reference_ratings` (with Harris' `load_zone_integrals`).
- **Static** bearings: `load_distribution` (the inner ring's displacement, each element's
  load and the load zone under a radial load, at any clearance or preload and cage position;
  a `LoadDistribution`) and the static form of `reference_life`.
- **Laws on arrays** (testable on synthetic histories): `revolution_weights`,
  `equivalent_load`, `rating_life`, `ball_race_load_ratings`, `ball_equivalent_load`, `ring_equivalent_load`, `ring_life`,
  `bearing_life`, `mean_speed_rpm`, `life_hours`, `reliability_factor` (ISO 281's a1).
- **On a `Solution`** of a model with a bearing joint: `iso_life`, `lp_life`,
  `reference_life` (a `ReferenceLife`), `l10_hours`, and `metric`, the L10 life as a metric
  (`LifeMetric`) of sweeps, sensitivities and tuning;
  `static_safety`, the ISO 76 static capacity (C_0r, the peak equivalent static load, s_0 and
  the contact stress). The lives apply the
  same rules to the integrals the solve records (`Solution.fatigue`, `solution.FatigueStats`: Gauss–Legendre quadrature of each
  accepted step's interpolant, per interval between the solve's stops), not to the output
  samples, so a life does not depend on ``ts``; the window's edges must be stops of the solve.
  `relative_speed` and `ring_point_loads` give the sampled histories (for plots, or the array
  laws).

Conventions (ISO 281:2007 and ISO/TR 1281-1 for variable loads; Harris & Kotzalas, *Rolling
Bearing Analysis*, 5th ed., Wiley 2006, *Advanced Concepts* ch. 8 for Lundberg–Palmgren):

- **Revolutions.** In a mechanism both rings turn; fatigue counts the stress cycles of the balls
  rolling over the raceways, which are proportional to the revolutions of one ring *relative
  to the other*. Every instant is therefore weighted by the relative revolutions turned in it,
  |omega_inner - omega_outer| dt / (2 pi) (trapezoid rule in time), and lives are in millions
  of relative revolutions. A load carried while the rings do not turn relative to each other
  does not count. Short impacts count by the revolutions turned while they last (the
  standard's convention for variable loads), not as extra stress cycles.
- **Window.** ``[t_min, t_max]``. On a `Solution` the default (``t_min="model"``) starts at the
  model's ``window_start`` (`Mechanism`; `cases.xu2014` after its start-up transient; None: the
  whole span); on arrays the default (None) is the whole history. On arrays, the weights integrate the samples'
  piecewise-linear interpolant over the window exactly, edges between samples included
  (`metrics.window_weights`, the rule of `metrics.window` too); on a `Solution`, the window is
  a union of the solve's stop intervals.
- **Hours.** L10h = 1e6 L10 / (60 n), n the mean relative speed [rpm] over the window.
- **Units.** Inputs in SI (m, rad, N, s, rad/s); the standard's formulas run in N and mm inside.

Concrete inputs are validated with a `ValueError` naming the parameter; traced inputs are not
checked here.
"""

from ._formulas import (
    ball_equivalent_load,
    bearing_life,
    equivalent_load,
    life_hours,
    mean_speed_rpm,
    rating_life,
    revolution_weights,
    reliability_factor,
    ring_equivalent_load,
    ring_life,
)
from ._distribution import LoadDistribution, load_distribution
from ._ratings import (
    B_M,
    B_M_ROLLER,
    FC_RATIO,
    FC_ROLLER_RATIO,
    FC_ROLLER_TABLE,
    FC_TABLE,
    F0_RATIO,
    F0_TABLE,
    ISO_REDUCTION,
    ball_race_load_ratings,
    dynamic_load_rating,
    dynamic_rating,
    load_rating_factor,
    roller_dynamic_load_rating,
    roller_load_rating_factor,
    roller_static_load_rating,
    static_load_factor,
    static_load_rating,
)
from ._reference import ReferenceLife, load_zone_integrals, reference_ratings
from ._solution import (
    LPLife,
    LifeMetric,
    RatingLife,
    iso_life,
    l10_hours,
    lp_life,
    metric,
    reference_life,
    relative_speed,
    ring_point_loads,
)
from ._static import (
    PERMISSIBLE_BALL,
    PERMISSIBLE_ROLLER,
    StaticSafety,
    element_contact_stress,
    static_rating,
    static_safety,
)

__all__ = [
    "B_M",
    "B_M_ROLLER",
    "FC_RATIO",
    "FC_ROLLER_RATIO",
    "FC_ROLLER_TABLE",
    "FC_TABLE",
    "F0_RATIO",
    "F0_TABLE",
    "ISO_REDUCTION",
    "LPLife",
    "LifeMetric",
    "LoadDistribution",
    "PERMISSIBLE_BALL",
    "PERMISSIBLE_ROLLER",
    "RatingLife",
    "ReferenceLife",
    "StaticSafety",
    "ball_equivalent_load",
    "ball_race_load_ratings",
    "bearing_life",
    "dynamic_load_rating",
    "dynamic_rating",
    "element_contact_stress",
    "equivalent_load",
    "iso_life",
    "l10_hours",
    "life_hours",
    "load_distribution",
    "load_rating_factor",
    "load_zone_integrals",
    "lp_life",
    "metric",
    "mean_speed_rpm",
    "rating_life",
    "relative_speed",
    "reference_life",
    "reference_ratings",
    "reliability_factor",
    "revolution_weights",
    "ring_equivalent_load",
    "ring_life",
    "ring_point_loads",
    "roller_dynamic_load_rating",
    "roller_load_rating_factor",
    "roller_static_load_rating",
    "static_load_factor",
    "static_load_rating",
    "static_rating",
    "static_safety",
]
