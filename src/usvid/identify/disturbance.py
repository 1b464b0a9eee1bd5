r"""What nobody logged, estimated with the hull: a constant current and constant sway-force and
yaw-moment biases per trial, parameters of the output-error fit.

Current (Fossen 2021, ch. 10.3; :mod:`usvid.models.environment.current`): each trial ``k`` has
a constant, uniform current with the velocity over ground :math:`v_c^n = (c_{N,k}, c_{E,k})`
[m/s, north, east: the direction it flows TOWARDS]. The kind's states are the velocities
through the water; the integration core adds the current to the kinematics and to the recorded
velocities over ground, so that the simulated ``u``, ``v`` compared with the measured ones are

.. math:: u = u_r + c_N \cos\psi + c_E \sin\psi, \qquad v = v_r - c_N \sin\psi + c_E \cos\psi.

A current is seen by the output error only through the turn of this vector with the heading
(and through the hull's response to the water-relative velocity): the window's estimated
initial state absorbs a current that the heading does not turn. Straight runs therefore do not
separate it; the collinearity warning says so.

Bias: a constant external force on the hull in body axes per trial, sway force
:math:`Y_{b,k}` [N] and yaw moment :math:`N_{b,k}` [N m] (the unlogged wind's and waves'
mean loads, an asymmetric hull or thrust), added to the kind's right-hand side as the core's
external force (X, Y, K, N) = (0, Y_b, 0, N_b). In kinds whose thrust is in command units
(``thrust_per_command`` 1), the biases are in the same units as the thrust.

Both are constant within a trial: a disturbance that changes through a trial leaves residuals
the fit reports (and a trial cut into parts, ``LOG:T0:T1``, gets one value per part).

Units: SI, velocities [m/s], forces [N], moments [N m]; directions in the JSON in degrees, as
named.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from usvid.errors import IdentificationError, UsvidError
from usvid.identify.series import IdentificationWarning

#: The terms of ``--disturbance`` and the per-trial quantities each adds (fit names
#: ``QUANTITY[TRIAL INDEX]``).
TERMS = {"current": ("current_north", "current_east"), "bias": ("bias_Y", "bias_N")}
#: Units of the quantities.
UNITS = {"current_north": "m/s", "current_east": "m/s", "bias_Y": "N", "bias_N": "N m"}
#: The integration core's input series each quantity drives (:data:`usvid.sim.layout.SERIES`).
SERIES_OF = {"current_north": "current_x", "current_east": "current_y", "bias_Y": "force_Y",
             "bias_N": "force_N"}
#: A disturbance parameter whose estimate correlates with another parameter by more than this
#: (absolute correlation of the fit's covariance) is reported as not separable.
CORR_MAX = 0.95


def parse_disturbance(text: str | Sequence[str] | None) -> tuple[str, ...]:
    """The terms of ``--disturbance`` (``"current"``, ``"bias"``, ``"current,bias"``; empty or
    ``"none"``: none), in :data:`TERMS` order. Raises :class:`UsvidError` naming the option."""
    if text is None:
        return ()
    items = text.split(",") if isinstance(text, str) else list(text)
    items = [s.strip().lower() for s in items if s.strip()]
    if items in ([], ["none"]):
        return ()
    bad = [s for s in items if s not in TERMS]
    if bad:
        raise UsvidError(f"--disturbance {','.join(items)!r}: unknown term(s) "
                         f"{', '.join(map(repr, bad))} (choose from: {', '.join(TERMS)}, "
                         "comma-separated, or none)")
    return tuple(t for t in TERMS if t in items)


@dataclass(frozen=True)
class Disturbance:
    """The disturbance parameters of an output-error fit: ``terms`` (keys of :data:`TERMS`)
    for each of the trials named ``trials`` (the windows' ``trial_index`` counts them)."""

    terms: tuple[str, ...]
    trials: tuple[str, ...]

    @property
    def quantities(self) -> tuple[str, ...]:
        return tuple(q for t in self.terms for q in TERMS[t])

    @property
    def names(self) -> tuple[str, ...]:
        """Fit names, trial by trial: ``current_north[0]``, ``current_east[0]``, ..."""
        return tuple(f"{q}[{k}]" for k in range(len(self.trials)) for q in self.quantities)

    def values(self, x: np.ndarray, names: Sequence[str]) -> np.ndarray:
        """(n_trials, n_quantities) of the fit vector ``x`` (names ``names``)."""
        idx = [list(names).index(n) for n in self.names]
        return np.asarray(x, float)[idx].reshape(len(self.trials), len(self.quantities))

    def series(self, x: np.ndarray, names: Sequence[str], trial_index: np.ndarray,
               width: int) -> dict[str, np.ndarray]:
        """The core's input series (B, width) of the windows (trial of window b:
        ``trial_index[b]``): each quantity constant in time at its trial's value."""
        vals = self.values(x, names)[np.asarray(trial_index, int)]
        return {SERIES_OF[q]: np.repeat(vals[:, j:j + 1], width, axis=1)
                for j, q in enumerate(self.quantities)}


def disturbance_for(kind: Any, terms: Sequence[str], trials: Sequence[str]) -> Disturbance | None:
    """The :class:`Disturbance` of ``terms`` for a fit of ``kind`` (None without terms);
    refuses kinds that cannot carry it (a constant-speed response model has no surge or sway
    state to carry a current, and its rudder offset ``delta0`` already is its yaw bias)."""
    terms = tuple(terms)
    if not terms:
        return None
    if kind.constant_speed:
        raise IdentificationError(
            f"--disturbance {','.join(terms)}: a {kind.name} model moves at a constant speed "
            "with no surge or sway state, so a current cannot enter it, and its rudder offset "
            "delta0 already is a constant yaw bias; use a kind with surge and sway (threedof, "
            "catamaran, mmg)")
    return Disturbance(terms, tuple(trials))


def report(dist: Disturbance, x: np.ndarray, names: Sequence[str], cov: np.ndarray,
           q: float, free: Sequence[str], kind: str) -> dict[str, Any]:
    """The JSON-ready per-trial values with their 95 % intervals (``q`` the interval's
    quantile, ``cov`` the fit-space covariance over ``names``) and the separability verdict.

    Keys: ``terms``; ``trials``: one object per trial, ``trial`` its name, per quantity
    ``{"value", "std_error", "ci95", "unit"}``, with a current also its ``current_speed_m_s``
    and ``current_towards_deg`` (direction it flows towards, from north, clockwise);
    ``not_separable``: the quantities whose estimate correlates with another parameter above
    :data:`CORR_MAX` (with that parameter and the correlation) or whose interval is not
    finite; ``warning``: the text warned (None: all separable). Warns
    (:class:`IdentificationWarning`) when something is not separable."""
    names = list(names)
    cov = np.asarray(cov, float)
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sd, sd)
    fidx = [names.index(n) for n in free]
    vals = dist.values(x, names)
    trials, bad = [], []
    for k, tname in enumerate(dist.trials):
        row: dict[str, Any] = {"trial": tname}
        for j, qn in enumerate(dist.quantities):
            i = names.index(f"{qn}[{k}]")
            v, se = float(vals[k, j]), float(sd[i])
            row[qn] = {"value": v, "std_error": se, "ci95": [v - q * se, v + q * se],
                       "unit": UNITS[qn]}
            others = [(abs(float(corr[i, m])), names[m]) for m in fidx if m != i
                      and math.isfinite(float(corr[i, m]))]
            worst = max(others, default=(0.0, ""))
            if not (math.isfinite(se) and se > 0.0):
                bad.append({"quantity": f"{qn}[{tname}]", "reason": "no finite interval"})
            elif worst[0] > CORR_MAX and not any(  # each pair once
                    b.get("with") == f"{qn}[{tname}]" and b["quantity"] == _plain(worst[1], dist)
                    for b in bad):
                bad.append({"quantity": f"{qn}[{tname}]", "with": _plain(worst[1], dist),
                            "correlation": round(worst[0], 4)})
        if "current" in dist.terms:
            cn, ce = row["current_north"]["value"], row["current_east"]["value"]
            row["current_speed_m_s"] = float(math.hypot(cn, ce))
            row["current_towards_deg"] = float(math.degrees(math.atan2(ce, cn)) % 360.0)
        trials.append(row)
    text = None
    if bad:
        parts = [f"{b['quantity']} with {b['with']} (correlation {b['correlation']:.3f})"
                 if "with" in b else f"{b['quantity']} ({b['reason']})" for b in bad[:6]]
        more = f" and {len(bad) - 6} more" if len(bad) > 6 else ""
        text = (f"{kind}: the disturbance is not separable from the hull in these data "
                f"(collinear: {'; '.join(parts)}{more}): its values and the correlated "
                "parameters are not determined separately; runs with turns through a wide range "
                "of headings (a current) and turns to both sides (a bias) separate them")
        warnings.warn(text, IdentificationWarning, stacklevel=3)
    return {"terms": list(dist.terms), "trials": trials, "not_separable": bad,
            "warning": text}


def _plain(name: str, dist: Disturbance) -> str:
    """A fit name with its trial's name in place of the index (``bias_N[run.csv]``)."""
    if name.endswith("]") and "[" in name:
        q, _, k = name[:-1].partition("[")
        try:
            return f"{q}[{dist.trials[int(k)]}]"
        except (ValueError, IndexError):
            return name
    return name


__all__ = ["CORR_MAX", "Disturbance", "SERIES_OF", "TERMS", "UNITS", "disturbance_for",
           "parse_disturbance", "report"]
