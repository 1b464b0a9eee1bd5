"""usvid.prep: from a raw trial to an identification-ready one, and what the data say.

Geodetic -> local NED (:func:`to_ned`), stale GNSS fixes (:func:`drop_stale`), multi-rate
alignment (:func:`resample`), zero-phase filtering and derivatives (:func:`savgol_derivative`),
body velocities, the one-call :func:`prepare` (a :class:`PreparedTrial`, made once per log and
command), the channel :func:`audit` and merging the logs of
several loggers (:func:`merge_trials`). Finding and measuring manoeuvres in a log is one layer up,
in :mod:`usvid.manoeuvres`.

The modules of the heavy libraries load on first use of their names (PEP 562): the channel
audit (pandas, scipy.signal), the state estimation (pandas, numba) and the merge of loggers
(pandas); importing a light module of the package (``usvid.prep.filters``, as
:mod:`usvid.manoeuvres` and :mod:`usvid.sim` do) loads neither pandas nor scipy. ``prepare``
and ``resample`` share their names with their modules and are imported here at once (their
modules are light).
"""

from typing import TYPE_CHECKING

from usvid.lazy import lazy_names
from usvid.prep.filters import (
    lowpass,
    savgol_derivative,
    savgol_smooth,
    unwrap_angle,
    window_samples,
    wrap_angle,
)
from usvid.prep.geodesy import geodetic_to_ned, to_ned
from usvid.prep.kinematics import (
    body_to_earth,
    body_velocity_from_cog,
    body_velocity_from_positions,
    earth_to_body,
)
from usvid.prep.prepare import PreparedTrial, as_prepared, prepare, sort_time
from usvid.prep.resample import infer_rate, resample
from usvid.prep.stale import StaleReport, detect_stale, drop_stale

if TYPE_CHECKING:
    from usvid.prep.channel_audit import audit, position_scale
    from usvid.prep.merge import merge_trials
    from usvid.prep.state_estimation import StateEstimate, estimate_states

#: Public name -> the module that defines it, for the names loaded on first use.
_LAZY = {
    "audit": "usvid.prep.channel_audit",
    "position_scale": "usvid.prep.channel_audit",
    "merge_trials": "usvid.prep.merge",
    "StateEstimate": "usvid.prep.state_estimation",
    "estimate_states": "usvid.prep.state_estimation",
}


__getattr__, __dir__ = lazy_names(__name__, _LAZY)


__all__ = [
    "PreparedTrial",
    "StaleReport",
    "StateEstimate",
    "as_prepared",
    "audit",
    "body_to_earth",
    "body_velocity_from_cog",
    "body_velocity_from_positions",
    "detect_stale",
    "drop_stale",
    "earth_to_body",
    "estimate_states",
    "merge_trials",
    "geodetic_to_ned",
    "infer_rate",
    "lowpass",
    "position_scale",
    "prepare",
    "resample",
    "savgol_derivative",
    "savgol_smooth",
    "sort_time",
    "to_ned",
    "unwrap_angle",
    "window_samples",
    "wrap_angle",
]
