r"""Wind as an input: constants, logged time series and seeded gusts from a published spectrum.

Conventions: true wind speed [m/s] and the direction it comes FROM [rad, from north, clockwise]
(the Trial's ``wind_speed_true``, ``wind_dir_true``); gusts vary the speed along the mean
direction (longitudinal turbulence only).

Gust spectra, one-sided in the frequency f [Hz], S(f) [(m/s)^2 / Hz], for the mean speed
:math:`\bar U_{10}` [m/s] at 10 m (both as given in Fossen 2021, ch. 10.1, and DNV-RP-C205 2010,
section 2.3):

* Harris (1971): :math:`S(f) = \dfrac{4 \kappa L \bar U_{10}}{(2 + \tilde f^2)^{5/6}}`,
  :math:`\tilde f = L f / \bar U_{10}`, L = 1800 m, :math:`\kappa` = 0.0026 (surface drag
  coefficient); its variance is :math:`0.0174\,\bar U_{10}^2` (a turbulence intensity of 13 %).
* NORSOK N-003 (2007), from Andersen & Lovseth (1992, 2006) (the "NORSEPP"/API spectrum):
  :math:`S(f) = \dfrac{320 (\bar U_{10}/10)^2 (z/10)^{0.45}}{(1 + \tilde f^n)^{5/(3n)}}`,
  :math:`\tilde f = 172 f (z/10)^{2/3} (\bar U_{10}/10)^{-0.75}`, n = 0.468, z [m] the height
  (:math:`\bar U_{10}` the one-hour mean at 10 m).

Realisation: the random-phase component sum of :mod:`usvid.models.environment._spectral` in
log-spaced bins (turbulence spans decades of frequency), lane b from ``default_rng([seed, b])``:
:math:`U(t) = \bar U + \sum_k a_k \cos(2\pi f_k t + \phi_k)`, floored at 0 (a gust cannot
reverse the mean wind).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from usvid.errors import UsvidError
from usvid.models.environment._spectral import components, sum_cos

#: Harris (1971): length scale [m] and surface drag coefficient [-].
HARRIS_L, HARRIS_KAPPA = 1800.0, 0.0026
#: NORSOK N-003 exponent.
NORSOK_N = 0.468
GUST_SPECTRA = ("norsok", "harris")


def harris_spectrum(f: Any, mean_speed: float) -> np.ndarray:
    """Harris (1971) gust spectrum S(f) [(m/s)^2/Hz] at ``f`` [Hz] for the mean wind
    ``mean_speed`` [m/s] at 10 m (module docstring)."""
    f = np.asarray(f, dtype=float)
    u = float(mean_speed)
    return 4.0 * HARRIS_KAPPA * HARRIS_L * u / (2.0 + (HARRIS_L * f / u) ** 2) ** (5.0 / 6.0)


def norsok_spectrum(f: Any, mean_speed: float, z: float = 10.0) -> np.ndarray:
    """NORSOK N-003 (Andersen & Lovseth) gust spectrum S(f) [(m/s)^2/Hz] at ``f`` [Hz] for the
    one-hour mean wind ``mean_speed`` [m/s] at 10 m, at height ``z`` [m] (module docstring)."""
    f = np.asarray(f, dtype=float)
    u = float(mean_speed)
    ft = 172.0 * f * (z / 10.0) ** (2.0 / 3.0) * (u / 10.0) ** -0.75
    n = NORSOK_N
    return 320.0 * (u / 10.0) ** 2 * (z / 10.0) ** 0.45 / (1.0 + ft**n) ** (5.0 / (3.0 * n))


def gust_spectrum(name: str, mean_speed: float, z: float = 10.0
                  ) -> Callable[[np.ndarray], np.ndarray]:
    """The spectrum ``name`` (``"norsok"`` or ``"harris"``) as a function of f [Hz]."""
    if name == "harris":
        return lambda f: harris_spectrum(f, mean_speed)
    if name == "norsok":
        return lambda f: norsok_spectrum(f, mean_speed, z)
    raise UsvidError(f"gusts: spectrum must be 'norsok' or 'harris' (got {name!r})")


def gust_series(t: Any, mean_speed: float, *, spectrum: str = "norsok", z: float = 10.0,
                seed: int = 0, n_batch: int = 1, n_components: int = 200,
                band: tuple[float, float] | None = None) -> np.ndarray:
    """Seeded gusty wind speed [m/s], shape (n_batch, n_t), at times ``t`` [s] around
    ``mean_speed`` [m/s] (module docstring). ``band`` [Hz]: the frequencies realised, default
    from 1/3600 Hz to the Nyquist frequency of ``t`` (at most 1 Hz). Lane b draws from
    ``default_rng([seed, b])``."""
    t = np.atleast_1d(np.asarray(t, dtype=float))
    if t.ndim != 1 or t.size < 2 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise UsvidError("gusts: t must be a 1-D increasing array of at least 2 times [s]")
    if not (isinstance(mean_speed, (int, float)) and math.isfinite(mean_speed)
            and mean_speed >= 0):
        raise UsvidError(f"gusts: mean_speed must be >= 0 m/s (got {mean_speed!r})")
    if not (isinstance(z, (int, float)) and math.isfinite(z) and z > 0):
        raise UsvidError(f"gusts: z must be > 0 m (got {z!r})")
    if mean_speed == 0:
        gust_spectrum(spectrum, 1.0)  # the name is still checked
        return np.zeros((int(n_batch), t.size))
    if band is None:
        nyquist = 0.5 / float(np.median(np.diff(t)))
        band = (1.0 / 3600.0, min(1.0, nyquist))
    f, a, ph = components(gust_spectrum(spectrum, float(mean_speed), float(z)), band[0],
                          band[1], n_components, seed, n_batch, log=True)
    u = np.full((f.shape[0], t.size), float(mean_speed))
    sum_cos(2.0 * np.pi * f, a, ph, np.ascontiguousarray(t), u)
    return np.maximum(u, 0.0)


def wind_on_grid(t: Any, speed: Any, direction: Any, t_source: Any = None
                 ) -> tuple[np.ndarray, np.ndarray]:
    """True wind (speed [m/s], direction [rad, from north, clockwise, coming from, in
    [0, 2 pi)]) on the times ``t`` [s]: constants, arrays already on ``t`` (also (n_batch, n_t),
    e.g. from :func:`gust_series`), or a logged series at times ``t_source`` [s] interpolated
    linearly (the direction unwrapped first, so that 350 -> 10 deg passes through north; held
    constant beyond the ends)."""
    t = np.atleast_1d(np.asarray(t, dtype=float))
    s = np.asarray(speed, dtype=float)
    d = np.asarray(direction, dtype=float)
    if t_source is not None:
        ts = np.asarray(t_source, dtype=float)
        if ts.ndim != 1 or s.shape != ts.shape or d.shape != ts.shape:
            raise UsvidError("wind series: speed and direction must have the shape of t_source "
                             f"(got {s.shape}, {d.shape}, {ts.shape})")
        ok = np.isfinite(ts) & np.isfinite(s) & np.isfinite(d)
        if ok.sum() < 1 or np.any(np.diff(ts[ok]) <= 0):
            raise UsvidError("wind series: t_source must increase and hold finite samples")
        s = np.interp(t, ts[ok], s[ok])
        d = np.interp(t, ts[ok], np.unwrap(d[ok]))
    if not (np.all(np.isfinite(s)) and np.all(np.isfinite(d))):
        raise UsvidError("wind series: speed and direction must be finite")
    if np.any(s < 0):
        raise UsvidError("wind series: speed must be >= 0 m/s")
    if (s.ndim and s.shape[-1] != t.size) or (d.ndim and d.shape[-1] != t.size):
        raise UsvidError(f"wind series: speed {s.shape} and direction {d.shape} do not match "
                         f"{t.size} times")
    s, d, _ = np.broadcast_arrays(s, d, t)
    return s.copy(), np.remainder(d, 2.0 * np.pi)
