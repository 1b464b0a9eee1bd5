"""IMO Standards for Ship Manoeuvrability, resolution MSC.137(76) (2002), section 5.

The criteria (a manoeuvre passes when the value does *not exceed* the limit, i.e. ``value <=
limit``; L = ship length [m], V = U = test speed [m/s]):

* turning ability (35 deg turning circle): advance <= 4.5 L, tactical diameter <= 5 L;
* initial turning ability (10 deg rudder): heading change of 10 deg before travelling 2.5 L;
* yaw checking, 10/10 zig-zag, first overshoot: 10 deg if L/V < 10 s, 20 deg if L/V >= 30 s,
  (5 + 0.5 L/V) deg in between;
* 10/10 zig-zag, second overshoot: 25 deg if L/V < 10 s, 40 deg if L/V >= 30 s,
  (17.5 + 0.75 L/V) deg in between;
* 20/20 zig-zag, first overshoot: 25 deg.

The Standards apply to ships of 100 m and more; for a small USV they are a yardstick, not a rule.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from usvid.errors import UsvidError

__all__ = [
    "Criterion",
    "ImoCheck",
    "first_overshoot_limit_10_10",
    "second_overshoot_limit_10_10",
    "imo_turning_applies",
    "imo_turning_check",
    "imo_zigzag_check",
    "zigzag_kind",
]


@dataclass
class Criterion:
    """One IMO criterion: ``value`` against ``limit`` (both in ``unit``); ``passed`` is
    ``value <= limit`` (``None`` when the value is unknown, e.g. the record was too short)."""

    name: str
    value: float
    limit: float
    unit: str
    passed: bool | None

    def to_dict(self) -> dict[str, Any]:
        return {"name": self.name, "value": self.value, "limit": self.limit, "unit": self.unit,
                "passed": self.passed}


@dataclass
class ImoCheck:
    """A set of IMO criteria for one manoeuvre; ``passed`` is True when every criterion was
    evaluated and passes, False when any fails, ``None`` otherwise (a metric could not be
    computed: a verdict on the others alone would pass a test that was not completed)."""

    manoeuvre: str
    criteria: list[Criterion] = field(default_factory=list)

    @property
    def passed(self) -> bool | None:
        verdicts = [c.passed for c in self.criteria]
        if False in verdicts:
            return False
        if not verdicts or None in verdicts:
            return None
        return True

    def to_dict(self) -> dict[str, Any]:
        return {"manoeuvre": self.manoeuvre, "passed": self.passed,
                "criteria": [c.to_dict() for c in self.criteria]}


def _check_LU(L: float, U: float | None = None) -> None:
    if L is None or not (isinstance(L, (int, float)) and math.isfinite(L) and L > 0):
        raise UsvidError(f"IMO check: vessel length L must be > 0 m (got {L!r})")
    if U is not None and not (math.isfinite(U) and U > 0):
        raise UsvidError(f"IMO check: speed U must be > 0 m/s (got {U!r})")


def _crit(name: str, value: float | None, limit: float, unit: str) -> Criterion:
    if value is None or not math.isfinite(value):
        return Criterion(name, math.nan if value is None else float(value), limit, unit, None)
    return Criterion(name, float(value), float(limit), unit, bool(value <= limit))


def _lu_limit(L: float, U: float, low: float, high: float, a: float, b: float) -> float:
    """Overshoot limit [deg] as a function of L/U [s]: ``low`` below 10 s, ``high`` from 30 s,
    ``a + b L/U`` in between (the MSC.137(76) 5.2.3 form)."""
    _check_LU(L, U)
    lu = L / U
    if lu < 10:
        return low
    if lu >= 30:
        return high
    return a + b * lu


def first_overshoot_limit_10_10(L: float, U: float) -> float:
    """Limit [deg] on the first overshoot of the 10/10 zig-zag (MSC.137(76) 5.2.3.1)."""
    return _lu_limit(L, U, 10.0, 20.0, 5.0, 0.5)


def second_overshoot_limit_10_10(L: float, U: float) -> float:
    """Limit [deg] on the second overshoot of the 10/10 zig-zag (MSC.137(76) 5.2.3.2)."""
    return _lu_limit(L, U, 25.0, 40.0, 17.5, 0.75)


def _get(metrics: Any, key: str) -> Any:
    if isinstance(metrics, dict):
        return metrics.get(key)
    return getattr(metrics, key, None)


def imo_turning_check(metrics: Any, L: float) -> ImoCheck:
    """Turning ability (MSC.137(76) 5.2.1): advance <= 4.5 L, tactical diameter <= 5 L.

    ``metrics`` is a :class:`usvid.manoeuvres.metrics.TurningMetrics` or its ``to_dict()``; L [m].
    Values (magnitudes) and limits are reported in metres. The Standards judge the circle at the
    maximum rudder angle; the caller decides whether the metrics are of such a circle.
    """
    _check_LU(L)
    # magnitudes: a signed value (e.g. a port turn, or a vessel backing) must not pass by being
    # negative
    adv, tac = _get(metrics, "advance_m"), _get(metrics, "tactical_diameter_m")
    return ImoCheck("turning", [
        _crit("advance", None if adv is None else abs(adv), 4.5 * L, "m"),
        _crit("tactical_diameter", None if tac is None else abs(tac), 5.0 * L, "m"),
    ])


def imo_zigzag_check(metrics: Any, L: float, U: float, kind: str = "10/10") -> ImoCheck:
    """Zig-zag criteria (MSC.137(76) 5.2.2 and 5.2.3) for a ``"10/10"`` or ``"20/20"`` test.

    ``metrics`` is a :class:`usvid.manoeuvres.metrics.ZigZagMetrics` or its ``to_dict()``; L [m],
    U [m/s]. For 10/10: first and second overshoot limits as functions of L/U, and the initial
    turning ability: track length (``initial_turning_distance_m`` when known, else
    ``U * initial_turning_time_s``) until the heading changed 10 deg <= 2.5 L. For 20/20: first
    overshoot <= 25 deg. Other kinds raise :class:`UsvidError`.
    """
    _check_LU(L, U)
    over = list(_get(metrics, "overshoot_deg") or [])
    first = over[0] if len(over) > 0 else None
    second = over[1] if len(over) > 1 else None
    if kind == "10/10":
        dist = _get(metrics, "initial_turning_distance_m")
        if dist is None or not math.isfinite(dist):
            t_it = _get(metrics, "initial_turning_time_s")
            dist = U * t_it if t_it is not None and math.isfinite(t_it) else None
        return ImoCheck("zigzag 10/10", [
            _crit("first_overshoot", first, first_overshoot_limit_10_10(L, U), "deg"),
            _crit("second_overshoot", second, second_overshoot_limit_10_10(L, U), "deg"),
            _crit("initial_turning_distance", dist, 2.5 * L, "m"),
        ])
    if kind == "20/20":
        return ImoCheck("zigzag 20/20", [_crit("first_overshoot", first, 25.0, "deg")])
    raise UsvidError(f"IMO check: zig-zag kind must be '10/10' or '20/20' (got {kind!r})")


def imo_turning_applies(delta: float, max_angle: float) -> bool:
    """True when a turning circle with the rudder at ``delta`` [rad] is one MSC.137(76) 5.2.1
    judges: at the maximum rudder angle, 35 deg or the steering gear's limit ``max_angle`` [rad]
    when that is smaller (a circle at a smaller angle gets no IMO verdict)."""
    return min(abs(delta), max_angle) >= min(math.radians(35.0), max_angle) - 1e-9


def zigzag_kind(delta_deg: float, psi_deg: float) -> str | None:
    """``"10/10"`` or ``"20/20"`` when the test is one the Standards judge, else ``None``."""
    for k in (10.0, 20.0):
        if abs(delta_deg - k) < 1e-6 and abs(psi_deg - k) < 1e-6:
            return f"{int(k)}/{int(k)}"
    return None
