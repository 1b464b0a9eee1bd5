"""Regressors of every model kind, and the maps from regression coefficients to model parameters.

Every model is put in the linear-in-the-coefficients form ``y = Phi theta + e`` (seed 000
eq. 37-40 identify it by recursive least squares; batch least squares gives the same estimate with
lambda = 1).

Response models (state r [rad/s], input delta [rad], rudder offset delta0 [rad] as a constant
regressor):

* ``nomoto1``, continuous form (seed 000 eq. 35 with alpha = 0; seed 001 eq. 21),
  ``T r' + r = K (delta + delta0)``  ->  ``r' = a r + b delta + c``,
  T = -1/a, K = -b/a, delta0 = c/b. r' from a Savitzky-Golay derivative of r; r and delta
  both enter through the same Savitzky-Golay smoother (``r_s``, ``delta_s``), so the regression
  is the filtered equation (smoothing r alone biases T by ~+3 % on a noise-free zig-zag).
* ``nomoto1``, discrete ARX form (seed 001 eq. 23 with one pole), zero-order hold at step h:
  ``r[k+1] = alpha r[k] + beta delta[k] + gamma``, alpha = exp(-h/T), beta = K (1 - alpha),
  gamma = beta delta0 (the d2c of a first-order system).
* ``nomoto2``, ARX(2,2) (seed 001 eq. 23 read as a 2nd-order discrete transfer function)
  ``r[k] = a1 r[k-1] + a2 r[k-2] + b1 delta[k-1] + b2 delta[k-2] + c``, converted to
  ``K (1 + T3 s) / ((1 + T1 s)(1 + T2 s))`` (seed 000 eq. 29, seed 001 eq. 18) by the matrix
  logarithm of the zero-order-hold state transition (the d2c of seed 001 eq. 24).
* ``norrbin`` joint fit with n1 free: ``T r' + n1 r + n3 r^3 = K (delta + delta0)`` ->
  ``r' = a1 r + a3 r^3 + b delta + c``. Only ratios to T are identifiable; we use Norrbin's own
  normalisation ``|n1| = 1``: T = 1/|a1|, n1 = -sign(a1) (= +1 course-stable, -1 course-unstable),
  n3 = -a3 T, K = b T, delta0 = c/b. With n1 = +1 this is seed 000 eq. 35 with alpha = n3.
* ``norrbin`` two-step (seed 000 remark 5/6): Nomoto from zig-zags, then alpha from the mean
  steady yaw rate of turning tests, eq. 36 ``r + alpha r^3 = K (delta + delta0)``:
  ``alpha = sum r_i^3 (K (delta_i + delta0) - r_i) / sum r_i^6``.

3-DOF (seed 000 eq. 37, Assumption 1; u [m/s], v [m/s], r [rad/s], tau_u [N], tau_r [N m])::

    u' = a_vr v r + a_u u + a_tau tau_u
    v' = b_ur u r + b_v v
    r' = c_uv u v + c_r r + c_tau tau_r

with a_vr = m22/m11, a_u = -d11/m11, a_tau = 1/m11, b_ur = -m11/m22, b_v = -d22/m22,
c_uv = (m11 - m22)/m33, c_r = -d33/m33, c_tau = 1/m33 (seed 000 eq. 17; the extracted text loses
the signs, these are the Fossen signs). tau from the trial's ``tau_u``/``tau_r`` columns, or from a
thrust model: tau_u = T cos(delta), tau_r = x_l T sin(delta) (ARCHITECTURE sign convention).

Twin-thruster catamaran (seed 002; its equations are missing from the extracted text, the standard
published form of :mod:`usvid.models.catamaran` is used): the same three equations with
tau_u = T_port + T_stbd and tau_r = (T_port - T_stbd) b/2. Thrusts from logged ``T_port``,
``T_stbd`` [N], or from the commands ``n_port``, ``n_stbd`` through a thrust map (``thrust(c)``,
e.g. ``TwinThrust.thrust``); without one the thrust is measured in command units (T = c, the
``Catamaran(thrust=1)`` convention), so a_tau = 1/m11 and c_tau = (b/2)/m33 are per command unit.
The thrust-speed relation and the damping follow from the same regression: on steady runs
u' = 0 gives d11/m11 u = tau_u/m11, i.e. the steady speed-thrust line u = -a_tau/a_u tau_u.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from usvid.errors import IdentificationError
from usvid.prep.filters import savgol_derivative, unwrap_angle, window_samples

KINDS = ("nomoto1", "nomoto2", "norrbin", "threedof", "catamaran")
MIN_SAMPLES = 30


class IdentificationWarning(UserWarning):
    """Data were usable only after a repair (gaps interpolated, grid resampled); says which."""


@dataclass
class Series:
    """One trial on a uniform grid, the arrays every regressor needs (SI units).

    ``h`` [s] step; measured ``t`` [s], ``psi`` [rad, unwrapped], ``r`` [rad/s], ``delta``
    [rad], optional ``u``, ``v`` [m/s], ``tau_u`` [N], ``tau_r`` [N m]; Savitzky-Golay smoothed
    states and rudder ``*_s`` (``r_s``, ``psi_s``, ``delta_s``, ...) and derivatives ``*dot_s``.
    """

    name: str
    h: float
    data: dict[str, np.ndarray] = field(default_factory=dict)

    def __getitem__(self, k: str) -> np.ndarray:
        return self.data[k]

    def __contains__(self, k: str) -> bool:
        return k in self.data

    def __len__(self) -> int:
        return len(self.data["t"])


def _uniform(trial, name: str) -> tuple[np.ndarray, float, bool]:
    t = np.asarray(trial.t, dtype=float)
    if len(t) < 2 or not np.all(np.diff(t) > 0):
        raise IdentificationError(f"trial {name}: time stamps must be strictly increasing")
    dt = np.diff(t)
    h = float(np.median(dt))
    uniform = bool(np.max(np.abs(dt - h)) <= 0.01 * h)
    return t, h, uniform


def _channel(trial, ch: str, name: str, t: np.ndarray, tg: np.ndarray) -> np.ndarray:
    x = trial[ch]
    bad = ~np.isfinite(x)
    nbad = int(bad.sum())
    if nbad:
        frac = nbad / len(x)
        if frac > 0.2 or nbad > len(x) - 2:
            raise IdentificationError(
                f"trial {name}: channel '{ch}' has {nbad} of {len(x)} samples NaN/inf "
                f"({100 * frac:.0f} %); repair or cut the log before identification")
        warnings.warn(f"trial {name}: channel '{ch}' has {nbad} NaN/inf samples; "
                      "interpolated linearly", IdentificationWarning, stacklevel=4)
        x = np.interp(t, t[~bad], x[~bad])
    if tg is not t:
        x = np.interp(tg, t, x)
    return x


def trial_series(trial, kind: str, *, smooth_s: float = 1.0,
                 thrust: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
                 x_l: float | None = None, half_beam: float | None = None) -> Series:
    """Extract the arrays of ``kind`` from a :class:`usvid.Trial` onto a uniform grid.

    Parameters
    ----------
    trial : usvid.Trial
        Needs ``delta`` and ``r`` or ``psi`` (response kinds); ``u``, ``v``, ``r`` and ``tau_u``,
        ``tau_r`` or a thrust source (``threedof``); ``n_port``, ``n_stbd`` or ``T_port``,
        ``T_stbd`` (``catamaran``).
    smooth_s : float
        Savitzky-Golay window [s] (cubic) for smoothed states and derivatives.
    thrust : callable ``(n [rps], u [m/s]) -> T [N]``
        Thrust model for ``threedof`` when the trial has ``n`` but no tau columns
        (e.g. ``usvid.models.thrust.Propeller(...).thrust``); needs ``x_l`` [m].
    half_beam : float
        b/2 [m] of a catamaran (default 1: then c_tau = (b/2)/m33 absorbs it); ``thrust`` for a
        catamaran maps one thruster's command to its thrust (``thrust(c) -> T``).

    Raises
    ------
    IdentificationError
        too short, a needed channel absent, too many NaN samples.
    """
    name = trial.name or (trial.sources[0] if trial.sources else "?")
    if len(trial) < MIN_SAMPLES:
        raise IdentificationError(
            f"trial {name}: too short for identification ({len(trial)} samples, "
            f"need >= {MIN_SAMPLES})")
    t, h, uniform = _uniform(trial, name)
    tg = t
    if not uniform:
        warnings.warn(f"trial {name}: time grid not uniform; resampled linearly to "
                      f"{1 / h:.3g} Hz", IdentificationWarning, stacklevel=3)
        tg = t[0] + h * np.arange(int(math.floor((t[-1] - t[0]) / h)) + 1)
    win = window_samples(smooth_s, h)
    if tg[-1] - tg[0] < 3 * smooth_s or len(tg) < 2 * win:
        raise IdentificationError(
            f"trial {name}: too short for identification ({tg[-1] - tg[0]:.1f} s; need at "
            f"least {max(3 * smooth_s, 2 * win * h):.1f} s with smoothing window {smooth_s} s)")
    d: dict[str, np.ndarray] = {"t": tg}

    def need(ch: str) -> np.ndarray:
        if ch in trial.channels and not trial.has(ch):
            raise IdentificationError(
                f"trial {name}: channel '{ch}' (needed by model '{kind}') has no finite sample "
                f"(all {len(trial)} NaN/inf); check its column in the format spec")
        if not trial.has(ch):
            raise IdentificationError(
                f"trial {name}: model '{kind}' needs channel '{ch}' (present: "
                f"{', '.join(trial.channels) or 'none'})")
        return _channel(trial, ch, name, t, tg)

    def sg(x: np.ndarray, deriv: int = 0) -> np.ndarray:
        return savgol_derivative(x, h, smooth_s, 3, deriv=deriv)

    if kind in ("nomoto1", "nomoto2", "norrbin"):
        d["delta"] = need("delta")
        # the same filter as r_s: the regression sees both sides of the equation through one
        # linear filter (smoothing only r biases T, e.g. +2.6 % on a noise-free zig-zag)
        d["delta_s"] = sg(d["delta"])
    if trial.has("psi"):
        d["psi"] = unwrap_angle(need("psi"))
    if trial.has("r"):
        d["r"] = need("r")
    elif "psi" in d:
        d["r"] = sg(d["psi"], 1)
    else:
        raise IdentificationError(f"trial {name}: needs channel 'r' or 'psi' (present: "
                                  f"{', '.join(trial.channels) or 'none'})")
    if "psi" not in d:
        d["psi"] = np.concatenate([[0.0], np.cumsum(0.5 * h * (d["r"][1:] + d["r"][:-1]))])
    d["r_s"] = sg(d["r"])
    d["rdot_s"] = sg(d["r"], 1)
    d["psi_s"] = sg(d["psi"])
    if kind in ("threedof", "catamaran"):
        for ch in ("u", "v"):
            d[ch] = need(ch)
            d[ch + "_s"] = sg(d[ch])
            d[ch + "dot_s"] = sg(d[ch], 1)
    if kind == "threedof":
        if trial.has("tau_u") and trial.has("tau_r"):
            d["tau_u"] = need("tau_u")
            d["tau_r"] = need("tau_r")
        else:
            delta = need("delta")
            if trial.has("thrust"):
                T = need("thrust")
            elif thrust is not None and trial.has("n"):
                fn = thrust.thrust if hasattr(thrust, "thrust") else thrust
                T = np.asarray(fn(need("n"), d["u"]), dtype=float)
            else:
                raise IdentificationError(
                    f"trial {name}: model 'threedof' needs tau_u and tau_r, or a thrust channel, "
                    "or shaft speed 'n' plus a thrust model (seed 000 eq. 14)")
            if x_l is None:
                raise IdentificationError("model 'threedof' from thrust needs x_l [m], the lever "
                                          "of the vector thruster (seed 000 eq. 14)")
            d["tau_u"] = T * np.cos(delta)
            d["tau_r"] = x_l * T * np.sin(delta)
    if kind == "catamaran":
        hb = 1.0 if half_beam is None else float(half_beam)
        if trial.has("T_port") and trial.has("T_stbd"):
            tp, ts = need("T_port"), need("T_stbd")
        else:
            cp, cs = need("n_port"), need("n_stbd")
            if isinstance(thrust, (int, float)):
                tp, ts = float(thrust) * cp, float(thrust) * cs
            elif thrust is not None:
                fn = thrust.thrust if hasattr(thrust, "thrust") else thrust
                tp = np.asarray(fn(cp), dtype=float)
                ts = np.asarray(fn(cs), dtype=float)
            else:  # thrust in command units, T = c (usvid.models.catamaran.Catamaran thrust=1)
                tp, ts = cp, cs
        d["tau_u"] = tp + ts
        d["tau_r"] = (tp - ts) * hb
    return Series(name=name, h=h, data=d)


# ---------------------------------------------------------------------------------------------
@dataclass
class Regression:
    """Stacked regression ``y = Phi theta`` for one equation block (batch of trials stacked)."""

    Phi: np.ndarray
    y: np.ndarray
    names: tuple[str, ...]
    block: str = "r"
    trial_rows: list[int] = field(default_factory=list)


def _stack(blocks: list[tuple[np.ndarray, np.ndarray]], names, block) -> Regression:
    Phi = np.concatenate([b[0] for b in blocks])
    y = np.concatenate([b[1] for b in blocks])
    return Regression(Phi=Phi, y=y, names=tuple(names), block=block,
                      trial_rows=[len(b[1]) for b in blocks])


def _decimate(s: Series, h_target: float | None) -> tuple[int, float]:
    if h_target is None or h_target <= s.h:
        return 1, s.h
    m = max(int(round(h_target / s.h)), 1)
    return m, m * s.h


def regressions(kind: str, series: list[Series], *, form: str = "continuous",
                arx_step: float | None = None) -> list[Regression]:
    """Build the regression block(s) of ``kind`` (see the module docstring) over all trials.

    ``form`` is ``"continuous"`` (derivative regression) or ``"arx"`` (discrete, nomoto1/nomoto2
    only; ``arx_step`` [s] decimates to a step where the poles are not crowded at z = 1; default
    T/10-ish heuristic: 0.1 s for a 20-50 Hz log).
    """
    if kind == "nomoto2" or form == "arx":
        if kind not in ("nomoto1", "nomoto2"):
            raise IdentificationError(f"form 'arx' is available for nomoto1/nomoto2, not {kind}")
        blocks = []
        for s in series:
            m, _ = _decimate(s, arx_step)
            r = s["r_s"][::m]
            dl = s["delta_s"][::m]
            if kind == "nomoto1":
                blocks.append((np.column_stack([r[:-1], dl[:-1], np.ones(len(r) - 1)]), r[1:]))
            else:
                blocks.append((np.column_stack([r[1:-1], r[:-2], dl[1:-1], dl[:-2],
                                                np.ones(len(r) - 2)]), r[2:]))
        names = (("alpha", "beta", "gamma") if kind == "nomoto1"
                 else ("a1", "a2", "b1", "b2", "c"))
        return [_stack(blocks, names, "r")]
    if kind == "nomoto1":
        blocks = [(np.column_stack([s["r_s"], s["delta_s"], np.ones(len(s))]), s["rdot_s"])
                  for s in series]
        return [_stack(blocks, ("a", "b", "c"), "r")]
    if kind == "norrbin":
        blocks = [(np.column_stack([s["r_s"], s["r_s"] ** 3, s["delta_s"], np.ones(len(s))]),
                   s["rdot_s"]) for s in series]
        return [_stack(blocks, ("a1", "a3", "b", "c"), "r")]
    if kind in ("threedof", "catamaran"):
        bu = [(np.column_stack([s["v_s"] * s["r_s"], s["u_s"], s["tau_u"]]), s["udot_s"])
              for s in series]
        bv = [(np.column_stack([s["u_s"] * s["r_s"], s["v_s"]]), s["vdot_s"]) for s in series]
        br = [(np.column_stack([s["u_s"] * s["v_s"], s["r_s"], s["tau_r"]]), s["rdot_s"])
              for s in series]
        return [_stack(bu, ("a_vr", "a_u", "a_tau"), "u"), _stack(bv, ("b_ur", "b_v"), "v"),
                _stack(br, ("c_uv", "c_r", "c_tau"), "r")]
    raise IdentificationError(f"unknown model kind {kind!r}; expected one of {', '.join(KINDS)}")


# ---------------------------------------------------------------------------------------------
def d2c_arx2(a1: float, a2: float, b1: float, b2: float, h: float) -> np.ndarray:
    """Continuous (K, T1, T2, T3) of a ZOH-discretised 2nd-order system from its ARX(2,2) form.

    Discrete ``r[k] = a1 r[k-1] + a2 r[k-2] + b1 u[k-1] + b2 u[k-2]`` is the transfer function
    ``(b1 z + b2) / (z^2 - a1 z - a2)``; :func:`usvid.identify.d2c.d2c` (zero-order hold, matrix
    logarithm; seed 001 eq. 23 -> 24) gives ``(n1 s + n0)/(s^2 + d1 s + d0)``, hence
    K = n0/d0, T1 T2 = 1/d0, T1 + T2 = d1/d0, K T3 = n1/d0 (seed 000 eq. 29), T1 >= T2.
    Non-real or unstable continuous poles raise IdentificationError.
    """
    from usvid.models.d2c import d2c

    try:
        tf = d2c([b1, b2], [1.0, -a1, -a2], h)
    except IdentificationError as exc:
        raise IdentificationError(f"nomoto2: {exc}") from exc
    den = np.zeros(3)
    den[3 - len(tf.den):] = tf.den
    num = np.zeros(2)
    num[2 - len(tf.num):] = tf.num[-2:]
    _, d1, d0 = den
    n1, n0 = num
    disc = d1 * d1 - 4 * d0
    if tf.delay_samples or d0 <= 0 or d1 <= 0 or disc < 0:
        raise IdentificationError(
            f"nomoto2: continuous poles not real and stable (s^2 + {d1:.4g} s + {d0:.4g}); "
            "the data do not support a 2nd-order Nomoto model")
    s1 = (-d1 + math.sqrt(disc)) / 2
    s2 = (-d1 - math.sqrt(disc)) / 2
    T1, T2 = -1 / s1, -1 / s2
    K = n0 / d0
    T3 = (n1 / d0) / K if K != 0 else 0.0
    return np.array([K, T1, T2, T3])


def theta_to_params(kind: str, form: str, names: tuple[str, ...], theta: np.ndarray,
                    h: float) -> dict[str, float]:
    """Map regression coefficients to model parameters (module docstring), SI units."""
    th = dict(zip(names, np.asarray(theta, dtype=float), strict=True))
    if kind == "nomoto1" and form == "arx":
        al, be, ga = th["alpha"], th["beta"], th["gamma"]
        if not 0 < al < 1:
            raise IdentificationError(f"nomoto1 (ARX): pole alpha = {al:.6g} is not in (0, 1); "
                                      "the data do not show a stable first-order response")
        T = -h / math.log(al)
        K = be / (1 - al)
        return {"K": K, "T": T, "delta0": ga / be}
    if kind == "nomoto1":
        a, b, c = th["a"], th["b"], th["c"]
        return {"K": -b / a, "T": -1.0 / a, "delta0": c / b}
    if kind == "nomoto2":
        K, T1, T2, T3 = d2c_arx2(th["a1"], th["a2"], th["b1"], th["b2"], h)
        dc = (th["b1"] + th["b2"])
        return {"K": K, "T1": T1, "T2": T2, "T3": T3, "delta0": th["c"] / dc}
    if kind == "norrbin":
        a1, a3, b, c = th["a1"], th["a3"], th["b"], th["c"]
        T = 1.0 / abs(a1)
        return {"K": b * T, "T": T, "n1": -math.copysign(1.0, a1), "n3": -a3 * T,
                "delta0": c / b}
    return dict(th)


def steady_thrust_speed(series: list[Series], *, settle_s: float = 10.0,
                        min_steady_s: float = 5.0) -> dict[str, float] | None:
    """Thrust-speed line from the steady runs of twin-thruster (or 3-DOF) trials (seed 002).

    A steady run is a stretch where the surge input ``tau_u`` stays within 2 % of its range for at
    least ``settle_s + min_steady_s`` seconds; its last ``min_steady_s`` seconds (after the
    ``settle_s`` transient) give one point (mean u, mean tau_u). On straight steady runs
    u' = 0, so ``d11 u = tau_u`` (seed 002: the D matrix from speed/thrust runs): the slope
    ``d11_per_m11 / a_tau`` of tau_u over u through the origin is d11 in thrust units
    [thrust unit s/m]. Returns ``{"d11": ..., "se": ..., "n_runs": ...}`` or None when fewer than
    two steady runs are found.
    """
    us, ts = [], []
    for s in series:
        tu = s["tau_u"]
        rng = float(np.ptp(tu)) or 1.0
        n_set = int(round(settle_s / s.h))
        n_min = int(round(min_steady_s / s.h))
        start = 0
        for k in range(1, len(tu) + 1):
            if k == len(tu) or abs(tu[k] - tu[start]) > 0.02 * rng:
                if k - start >= n_set + n_min:
                    sl = slice(start + n_set, k)
                    if np.max(np.abs(s["r_s"][sl])) < 0.05:  # straight: yaw rate < 3 deg/s
                        us.append(float(np.mean(s["u_s"][sl])))
                        ts.append(float(np.mean(tu[sl])))
                start = k
    if len(us) < 2:
        return None
    u = np.array(us)
    t = np.array(ts)
    d11 = float(u @ t / (u @ u))
    res = t - d11 * u
    se = math.sqrt(float(res @ res) / (len(u) - 1) / float(u @ u))
    return {"d11": d11, "se": se, "n_runs": len(u)}
