"""Units a trial format spec may name, and their conversion to the SI units of the Trial contract.

Every unit is linear (``si = factor * value``); there are no affine units (temperatures) here.
A unit belongs to one *dimension*; a channel of the Trial contract accepts only units of its own
dimension (``psi`` takes ``deg`` or ``rad``, never ``m/s``). Channel ``lat``/``lon`` stay in degrees
(``usvid.trial.CHANNEL_UNITS``); every other channel is converted to SI.

Special unit ``datetime`` (time column only): text or Excel date-times, converted to seconds.
"""

from __future__ import annotations

import math

from usvid.trial import CHANNEL_UNITS

#: unit -> (dimension, factor to the dimension's SI unit)
UNITS: dict[str, tuple[str, float]] = {
    # time
    "s": ("time", 1.0),
    "ms": ("time", 1e-3),
    "us": ("time", 1e-6),
    "min": ("time", 60.0),
    "h": ("time", 3600.0),
    # length
    "m": ("length", 1.0),
    "cm": ("length", 0.01),
    "mm": ("length", 1e-3),
    "km": ("length", 1e3),
    "nmi": ("length", 1852.0),
    # angle
    "rad": ("angle", 1.0),
    "deg": ("angle", math.pi / 180.0),
    # angular rate
    "rad/s": ("angular_rate", 1.0),
    "deg/s": ("angular_rate", math.pi / 180.0),
    "deg/min": ("angular_rate", math.pi / 180.0 / 60.0),
    # speed
    "m/s": ("speed", 1.0),
    "kn": ("speed", 1852.0 / 3600.0),
    "km/h": ("speed", 1.0 / 3.6),
    # shaft/revolution rate
    "rps": ("revolution_rate", 1.0),
    "Hz": ("revolution_rate", 1.0),
    "rpm": ("revolution_rate", 1.0 / 60.0),
    # force and moment
    "N": ("force", 1.0),
    "kN": ("force", 1e3),
    "N*m": ("moment", 1.0),
    "kN*m": ("moment", 1e3),
    # electrical and dimensionless (thruster commands, PWM counts, ratios)
    "V": ("voltage", 1.0),
    "A": ("current", 1.0),
    "1": ("dimensionless", 1.0),
    "%": ("dimensionless", 0.01),
}

#: Spellings accepted as the same unit.
ALIASES: dict[str, str] = {
    "sec": "s",
    "deg/sec": "deg/s",
    "rad/sec": "rad/s",
    "knots": "kn",
    "kt": "kn",
    "kts": "kn",
    "kmh": "km/h",
    "Nm": "N*m",
    "N m": "N*m",
    "N.m": "N*m",
    "kNm": "kN*m",
    "rev/s": "rps",
    "rev/min": "rpm",
    "-": "1",
    "": "1",
    "degree": "deg",
    "degrees": "deg",
}

#: The special unit for date-time columns.
DATETIME = "datetime"


def canonical_unit(unit: str) -> str | None:
    """The canonical spelling of ``unit``, or ``None`` when it is unknown."""
    u = str(unit).strip()
    if u in UNITS or u == DATETIME:
        return u
    return ALIASES.get(u)


def known_units() -> list[str]:
    """All canonical unit names (for error messages)."""
    return [*UNITS, DATETIME]


def target_factor(channel: str, unit: str) -> float:
    """Factor turning a value in ``unit`` into the Trial unit of ``channel``.

    The Trial unit is ``CHANNEL_UNITS[channel]`` for contract channels (degrees for ``lat``/``lon``)
    and the SI unit of the dimension for any other channel. Raises ``ValueError`` with a plain
    sentence when the unit's dimension does not fit the channel.
    """
    dim, f_src = UNITS[unit]
    tgt = CHANNEL_UNITS.get(channel)
    if tgt is None or tgt not in UNITS:
        return f_src
    tdim, f_tgt = UNITS[tgt]
    if tdim != dim:
        raise ValueError(
            f"unit '{unit}' is a {dim.replace('_', ' ')}, but channel '{channel}' needs "
            f"a {tdim.replace('_', ' ')} (e.g. {tgt})"
        )
    return f_src / f_tgt
