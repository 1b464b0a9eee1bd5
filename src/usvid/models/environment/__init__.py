"""The environment a vessel moves in: wind, current and waves (no integration, no files).

Conventions (SI, radians; NED earth frame, body x forward, y starboard):

* wind: true wind speed [m/s] and the direction it comes FROM [rad, from north, clockwise];
  apparent wind speed [m/s] and angle [rad, from the bow, clockwise, coming FROM];
* current: speed [m/s] and the direction it flows TOWARDS [rad, from north, clockwise];
* waves: significant height [m], peak period [s] and the direction they come FROM [rad, from
  north, clockwise].

Modules:

* :mod:`.wind`: the wind triangle (apparent <-> true wind);
* :mod:`.wind_loads`: wind forces and moments (Fujiwara et al. 1998, Blendermann 1994), the
  model's selection from the vessel's particulars, ``wind_scale``, and the rudder-equivalent of a
  yaw moment for the response kinds;
* :mod:`.current`: body-frame current and the water-relative velocity (Fossen 2021, ch. 10.3);
* :mod:`.waves`: Pierson-Moskowitz and JONSWAP spectra, seeded realisations, first-order
  wave-induced motion and the mean wave drift force;
* :mod:`.gusts`: gust spectra (Harris, NORSOK) and seeded gust series; constants and logged
  series on a time grid.

The functions an integration core calls per step are numba-compiled scalars
(:func:`~.wind_loads.wind_load`, :func:`~.wind_loads.wind_load_true`,
:func:`~.current.water_relative_scalar`, :func:`~.current.ground_velocity_scalar`,
:func:`~.waves.mean_drift_scalar`, :func:`~.waves.wave_motion_scalar`); the array functions call
the same code.
"""

from usvid.models.environment.current import (
    current_body,
    current_ned,
    ground_velocity,
    ground_velocity_scalar,
    water_relative_scalar,
    water_relative_velocity,
)
from usvid.models.environment.gusts import (
    gust_series,
    harris_spectrum,
    norsok_spectrum,
    wind_on_grid,
)
from usvid.models.environment.waves import (
    SeaState,
    WaveMotion,
    drift_coefficients,
    first_order_response,
    jonswap,
    mean_drift_force,
    mean_drift_scalar,
    pierson_moskowitz,
    wave_components,
    wave_elevation,
    wave_motion,
    wave_motion_scalar,
)
from usvid.models.environment.wind import (
    apparent_to_true,
    true_to_apparent,
    true_to_apparent_scalar,
)
from usvid.models.environment.wind_loads import (
    AIR_DENSITY,
    BLENDERMANN_TYPES,
    WINDAGE_EXTRA,
    RudderEquivalent,
    WindLoadModel,
    WindLoads,
    rudder_equivalent,
    wind_coefficients,
    wind_load,
    wind_load_model,
    wind_load_true,
    wind_loads,
    yaw_inertia,
)

__all__ = [
    "AIR_DENSITY", "BLENDERMANN_TYPES", "WINDAGE_EXTRA", "RudderEquivalent", "SeaState",
    "WaveMotion", "WindLoadModel", "WindLoads", "apparent_to_true", "current_body",
    "current_ned", "drift_coefficients", "first_order_response", "ground_velocity",
    "ground_velocity_scalar", "gust_series", "harris_spectrum", "jonswap", "mean_drift_force",
    "mean_drift_scalar", "norsok_spectrum", "pierson_moskowitz", "rudder_equivalent",
    "true_to_apparent", "true_to_apparent_scalar", "water_relative_scalar",
    "water_relative_velocity", "wave_components", "wave_elevation", "wave_motion",
    "wave_motion_scalar", "wind_coefficients", "wind_load", "wind_load_model", "wind_load_true",
    "wind_loads", "wind_on_grid", "yaw_inertia",
]
