"""usvid.manoeuvres: standard manoeuvres, one definition each.

Layer: above :mod:`usvid.prep`, below :mod:`usvid.sim` (imports only ``usvid.trial``,
``usvid.errors``, ``usvid.prep``, numpy and scipy).

- :mod:`.logic`: what the helm or autopilot commands in a simulation (:class:`Turning`,
  :class:`ZigZag`, :class:`CourseChange` with :class:`PID`, :class:`Disturbance`,
  :class:`Commanded`).
- :mod:`.detect`: the one definition each of the rudder execute and side
  (:func:`find_execute`), plateau level and rudder amplitude (:func:`rudder_amplitude`), rudder
  rate (:func:`rudder_rate`), switching angle (:func:`nominal_switch`), zig-zag reversals
  (:func:`zigzag_crossings`) and steady turn (:func:`steady_turn`); manoeuvres found in a log
  (:func:`find_manoeuvres` -> :class:`Segment`; what it left out and why:
  :func:`manoeuvre_findings`).
- :mod:`.metrics`: zig-zag and turning-circle metrics of a time history (IMO MSC.137(76), ITTC
  7.5-04-02-01): :func:`zigzag_metrics`, :func:`turning_metrics`.
- :mod:`.drift`: the current measured by a turning test of 540 deg or more and the turning
  metrics corrected for it (IMO MSC/Circ.1053 3.4.2.5): :func:`imo_current`,
  :func:`current_corrected_turning`.
- :mod:`.measure`: the segments of a log measured with those metrics (:func:`measured_metrics`).
- :mod:`.imo`: the IMO MSC.137(76) criteria.

The names load with their modules on first use (PEP 562): the simulation imports only
:mod:`.logic` (``usvid.manoeuvres.logic``), and importing this package loads none of the
others (nor :mod:`usvid.prep`).
"""

from typing import TYPE_CHECKING

from usvid.lazy import lazy_names

if TYPE_CHECKING:
    from usvid.manoeuvres.detect import (
        Segment,
        SteadyTurn,
        find_execute,
        find_manoeuvres,
        manoeuvre_findings,
        nominal_switch,
        plateau_level,
        rudder_amplitude,
        rudder_rate,
        steady_turn,
        zigzag_crossings,
    )
    from usvid.manoeuvres.drift import (
        CurrentEstimate,
        current_corrected_track,
        current_corrected_turning,
        imo_current,
    )
    from usvid.manoeuvres.imo import (
        imo_turning_applies,
        imo_turning_check,
        imo_zigzag_check,
        zigzag_kind,
    )
    from usvid.manoeuvres.logic import PID, Commanded, CourseChange, Disturbance, Turning, ZigZag
    from usvid.manoeuvres.measure import manoeuvre_metrics, measured_metrics
    from usvid.manoeuvres.metrics import (
        TurningMetrics,
        ZigZagMetrics,
        turning_metrics,
        zigzag_metrics,
    )

#: Module -> the public names it defines (loaded on first use of any of them).
_MODULES = {
    "detect": ("Segment", "SteadyTurn", "find_execute", "find_manoeuvres", "manoeuvre_findings",
               "nominal_switch", "plateau_level", "rudder_amplitude", "rudder_rate",
               "steady_turn", "zigzag_crossings"),
    "drift": ("CurrentEstimate", "current_corrected_track", "current_corrected_turning",
              "imo_current"),
    "imo": ("imo_turning_applies", "imo_turning_check", "imo_zigzag_check", "zigzag_kind"),
    "logic": ("PID", "Commanded", "CourseChange", "Disturbance", "Turning", "ZigZag"),
    "measure": ("manoeuvre_metrics", "measured_metrics"),
    "metrics": ("TurningMetrics", "ZigZagMetrics", "turning_metrics", "zigzag_metrics"),
}
_LAZY = {name: f"{__name__}.{module}" for module, names in _MODULES.items() for name in names}
# (a submodule named as an attribute of the package is that submodule)
__getattr__, __dir__ = lazy_names(__name__, _LAZY, _MODULES)


__all__ = [
    "PID", "Commanded", "CourseChange", "CurrentEstimate", "Disturbance", "Segment",
    "SteadyTurn", "Turning", "TurningMetrics", "ZigZag", "ZigZagMetrics",
    "current_corrected_track", "current_corrected_turning", "find_execute", "find_manoeuvres",
    "imo_current",
    "imo_turning_applies", "imo_turning_check", "imo_zigzag_check", "manoeuvre_findings",
    "manoeuvre_metrics",
    "measured_metrics", "nominal_switch", "plateau_level", "rudder_amplitude", "rudder_rate",
    "steady_turn", "turning_metrics", "zigzag_crossings", "zigzag_kind", "zigzag_metrics",
]
