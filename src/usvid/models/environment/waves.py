r"""Irregular waves for simulation: sea-state spectra, a seeded realisation, the first-order
wave-induced motion and the mean wave drift force.

Conventions: a sea state is its significant wave height :math:`H_s` [m], peak period
:math:`T_p` [s] and the direction the waves come FROM [rad, from north, clockwise, as wave
reports and the wind]; internally :math:`\chi` is the direction they travel towards
(:math:`\chi = \text{from} + \pi`). Long-crested (one direction), deep water
(:math:`k = \omega^2/g`). Spectra are one-sided in the angular frequency :math:`\omega`
[rad/s], :math:`S(\omega)` [m^2 s/rad], :math:`m_0 = \int S\,d\omega = H_s^2/16`.

Spectra (DNV-RP-C205, 2010, section 3.5.5):

* Pierson-Moskowitz (Pierson & Moskowitz 1964), :math:`\omega_p = 2\pi/T_p`:
  :math:`S_{PM}(\omega) = \tfrac{5}{16} H_s^2 \omega_p^4 \omega^{-5}
  \exp(-\tfrac54 (\omega/\omega_p)^{-4})`;
* JONSWAP (Hasselmann et al. 1973): :math:`S_J = A_\gamma S_{PM}\,
  \gamma^{\exp(-(\omega-\omega_p)^2 / (2\sigma^2\omega_p^2))}`, :math:`A_\gamma = 1 - 0.287
  \ln\gamma` (normalises :math:`m_0` to within about 1 %), :math:`\sigma = 0.07` for
  :math:`\omega \le \omega_p`, 0.09 above; :math:`\gamma` = 3.3 by default (DNV: reasonable for
  :math:`3.6 < T_p/\sqrt{H_s} < 5`).

Realisation (:func:`wave_components`): the random-phase component sum of
:mod:`usvid.models.environment._spectral` in bins of equal log-width over the band holding all
but 0.1 % (low) and 0.5 % (high) of the energy (a realisation's :math:`H_s` is then 0.3 % low
on average), widened to the heading response's band when the vessel length is given. Elevation
at the point (x, y) [m, NED]:

.. math::

    \zeta(t) = \sum_k a_k \cos\theta_k, \qquad
    \theta_k = k_k (x\cos\chi + y\sin\chi) - \omega_k t + \phi_k.

With the vessel's own position in :math:`\theta_k` the encounter frequency follows by itself.

A batch of sea states (:class:`SeaState` with :math:`H_s`, :math:`T_p`, direction one per run)
uses that both spectra have one shape in :math:`\omega/\omega_p`: :math:`S(\omega; H_s, T_p) =
H_s^2 T_p S_1(\omega T_p)` with :math:`S_1` the spectrum of :math:`H_s` = 1 m, :math:`T_p` =
1 s. The elevation's band scales with :math:`1/T_p`; the heading response's band and the drift
integral depend on :math:`T_p` through the hull's length and draught and are integrated on
:math:`S_1`'s grid once per distinct :math:`T_p` (numba); the amplitudes are each run's own.
Run b then draws what its sea state alone draws, to rounding.

First-order wave-induced motion (:func:`wave_motion_scalar`): the component sum through the
vessel's motion response. usvid has no hydrodynamic RAO of a vessel, so it uses the long-wave
limit of a freely floating body: a body whose mass equals its displaced mass takes the
horizontal acceleration of the water around it (Froude-Krylov plus the diffraction force of
its added mass, the "G. I. Taylor" long-wave approximation; Newman 1977, Marine Hydrodynamics;
Faltinsen 1990, Sea Loads on Ships and Offshore Structures, ch. 3), and with a mass
distributed like the displacement a slender hull takes the rotation of the water's horizontal
displacement field along its length. The water's horizontal displacement in a deep-water Airy
wave is :math:`\xi = -a \sin\theta` along :math:`\chi`. Averaged over the hull length L (an
assumption of usvid: the least-squares fit of a rigid line to that displacement field, which
filters waves shorter than the hull), with :math:`\beta = \chi - \psi` the direction of travel
relative to the bow and :math:`h = k L \cos\beta / 2`:

.. math::

    \bar\xi_k = -a_k f_0(h) \sin\theta_k, \qquad
    \psi_{w} = \sum_k -\tfrac12 k_k a_k \sin 2\beta\, f_1(h) \cos\theta_k, \qquad
    f_0 = \frac{\sin h}{h}, \quad f_1 = \frac{3(\sin h - h\cos h)}{h^3},

position displacement :math:`(\bar\xi \cos\chi, \bar\xi \sin\chi)` [m, NED]. In long waves the
motion tends to the water's orbit (:math:`f_0, f_1 \to 1`). Superposed on the manoeuvring
(low-frequency) motion, as in Fossen (2021, ch. 10.2): :math:`\eta = \eta_{LF} + \eta_{WF}`; it
does not feed back into the manoeuvring model. At fixed heading and position its spectra are
:math:`|H(\omega)|^2 S(\omega)` with the response :math:`H` above
(:func:`first_order_response`).

Mean wave drift force (:func:`mean_drift_force`): the short-wave asymptote for a wall-sided hull
(Faltinsen 1990, ch. 5: :math:`\tfrac12\rho g\zeta_a^2 \int \sin^2(\theta+\beta) n\,dl` over the
side facing the waves), for a rectangular waterplane L x B, reduced for waves long against the
draught d by the reflected share of the incident power :math:`R^2 = 1 - e^{-2kd}` (the power
transmission theory of Wiegel 1960), summed over the spectrum:

.. math::

    X = \rho g B \cos\beta|\cos\beta| \int S R^2 d\omega, \qquad
    Y = \rho g L \sin\beta|\sin\beta| \int S R^2 d\omega, \qquad N = 0,

an estimate (a factor of about 2) that pushes the vessel where the waves travel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numba
import numpy as np

import usvid.jitcache  # noqa: F401 - numba's cache written best effort
from usvid.errors import UsvidError
from usvid.models.environment._spectral import components, energy_band

#: Gravity [m/s^2] (standard gravity).
G = 9.80665
#: Sea water density [kg/m^3].
RHO_WATER = 1025.0
SPECTRA = ("jonswap", "pm")


def pierson_moskowitz(omega: Any, hs: float, tp: float) -> np.ndarray:
    """Pierson-Moskowitz spectrum S(omega) [m^2 s/rad] for ``hs`` [m], ``tp`` [s] at ``omega``
    [rad/s] (DNV-RP-C205 eq. 3.5.5.1); 0 at omega <= 0."""
    w = np.asarray(omega, dtype=float)
    wp = 2.0 * np.pi / tp
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        s = 5.0 / 16.0 * hs**2 * wp**4 * w**-5.0 * np.exp(-1.25 * (w / wp) ** -4.0)
    return np.where(w > 0, s, 0.0)


def jonswap(omega: Any, hs: float, tp: float, gamma: float = 3.3) -> np.ndarray:
    """JONSWAP spectrum S(omega) [m^2 s/rad] (DNV-RP-C205 eq. 3.5.5.2): the Pierson-Moskowitz
    spectrum times ``(1 - 0.287 ln gamma) gamma^exp(-(w - wp)^2 / (2 sigma^2 wp^2))``, sigma
    0.07 below the peak and 0.09 above; ``gamma`` 1 is Pierson-Moskowitz."""
    w = np.asarray(omega, dtype=float)
    wp = 2.0 * np.pi / tp
    sigma = np.where(w <= wp, 0.07, 0.09)
    peak = gamma ** np.exp(-0.5 * ((w - wp) / (sigma * wp)) ** 2)
    return (1.0 - 0.287 * np.log(gamma)) * pierson_moskowitz(w, hs, tp) * peak


@dataclass(frozen=True)
class SeaState:
    """A long-crested sea state: ``hs`` [m] significant wave height, ``tp`` [s] peak period,
    ``direction`` [rad, from north, clockwise, where the waves come FROM], ``spectrum``
    ``"jonswap"`` or ``"pm"``, ``gamma`` [-] the JONSWAP peak enhancement.

    ``hs``, ``tp`` and ``direction`` may each be one value per run, a (B,) array (batch axis
    first; the others scalars or (B,) too): a batch of sea states, one per lane of a simulation
    (:attr:`batch` is then B; :meth:`lane` is run b's own sea state). ``spectrum`` and ``gamma``
    are shared by the batch."""

    hs: Any
    tp: Any
    direction: Any = 0.0
    spectrum: str = "jonswap"
    gamma: float = 3.3

    def __post_init__(self) -> None:
        size = None
        for name in ("hs", "tp", "direction"):
            v = getattr(self, name)
            positive = name != "direction"
            what = "must be > 0" if positive else "must be finite [rad]"
            if isinstance(v, (list, tuple, np.ndarray)):
                try:
                    a = np.array(v, dtype=float)
                except (TypeError, ValueError):
                    raise UsvidError(f"sea state: {name} must be numbers (got {v!r})") from None
                if a.ndim != 1 or a.size < 1:
                    raise UsvidError(f"sea state: {name} must be a number or one value per run "
                                     f"(a 1-D array; got shape {a.shape})")
                if size is not None and a.size != size:
                    raise UsvidError(f"sea state: {name} has {a.size} values, the others "
                                     f"{size} (one per run)")
                size = a.size
                bad = ~np.isfinite(a) | ((a <= 0) if positive else False)
                if np.any(bad):
                    i = int(np.argmax(bad))
                    raise UsvidError(f"sea state: {name} {what} (got {float(a[i])!r} for run {i})")
                a.flags.writeable = False
                object.__setattr__(self, name, a)
            elif not (isinstance(v, (int, float)) and not isinstance(v, bool)
                      and math.isfinite(v) and (v > 0 or not positive)):
                raise UsvidError(f"sea state: {name} {what} (got {v!r})")
        if self.spectrum not in SPECTRA:
            raise UsvidError(f"sea state: spectrum must be 'jonswap' or 'pm' "
                             f"(got {self.spectrum!r})")
        if not (isinstance(self.gamma, (int, float)) and 1.0 <= self.gamma <= 7.0):
            raise UsvidError(f"sea state: gamma must be in [1, 7] (got {self.gamma!r})")

    @property
    def batch(self) -> int | None:
        """The number of sea states of a batch (one per run), None for one sea state."""
        for v in (self.hs, self.tp, self.direction):
            if isinstance(v, np.ndarray):
                return int(v.size)
        return None

    def lane(self, b: int) -> SeaState:
        """Run b's sea state (one sea state: itself)."""
        if self.batch is None:
            return self

        def one(v: Any) -> float:
            return float(v[b]) if isinstance(v, np.ndarray) else float(v)
        return SeaState(one(self.hs), one(self.tp), one(self.direction), self.spectrum,
                        self.gamma)

    def collapsed(self) -> SeaState:
        """One sea state when every run of a batch has the same (run 0's: the same numbers as
        that sea state given alone), else the batch itself."""
        if self.batch is None:
            return self
        if all(not isinstance(v, np.ndarray) or np.all(v == v[0])
               for v in (self.hs, self.tp, self.direction)):
            return self.lane(0)
        return self

    def _lanewise(self, v: Any, ndim: int) -> Any:
        """A batch parameter shaped (B, 1, ...) against an ``ndim``-dimensional frequency array
        whose first axis is the run."""
        if isinstance(v, np.ndarray) and ndim > 1:
            return v.reshape((-1,) + (1,) * (ndim - 1))
        return v

    @property
    def omega_p(self) -> Any:
        """Peak frequency [rad/s] (a (B,) array for a batch)."""
        return 2.0 * math.pi / self.tp

    @property
    def chi(self) -> Any:
        """Direction the waves travel towards [rad, from north, clockwise] (a (B,) array for a
        batch)."""
        return (self.direction + math.pi) % (2.0 * math.pi)

    def density(self, omega: Any) -> np.ndarray:
        """S(omega) [m^2 s/rad] at ``omega`` [rad/s]; for a batch, the first axis of ``omega``
        is the run (shape (B, ...), or (B,) one frequency per run)."""
        w = np.asarray(omega, dtype=float)
        hs, tp = self._lanewise(self.hs, w.ndim), self._lanewise(self.tp, w.ndim)
        if self.spectrum == "pm":
            return pierson_moskowitz(w, hs, tp)
        return jonswap(w, hs, tp, self.gamma)

    def unit(self) -> SeaState:
        """The sea state of this spectrum with H_s = 1 m, T_p = 1 s: S(omega; H_s, T_p) =
        H_s^2 T_p S_1(omega T_p) for both spectra (their shape depends on omega / omega_p
        only), so one spectrum shape serves a batch."""
        return SeaState(1.0, 1.0, 0.0, self.spectrum, self.gamma)

    def band(self) -> tuple[Any, Any]:
        """[omega_lo, omega_hi] [rad/s] holding all but 0.1 % (low) and 0.5 % (high) of m0;
        for a batch two (B,) arrays, the unit spectrum's band over T_p (:meth:`unit`)."""
        if self.batch is None:
            return energy_band(self.density, self.omega_p)
        lo, hi = self.unit().band()
        tp = np.broadcast_to(np.asarray(self.tp, dtype=float), (self.batch,))
        return lo / tp, hi / tp

    def to_dict(self) -> dict[str, Any]:
        def num(v: Any) -> Any:
            if not isinstance(v, np.ndarray):
                return v
            return {"mean": float(np.mean(v)), "min": float(np.min(v)), "max": float(np.max(v))}
        return {"hs_m": num(self.hs), "tp_s": num(self.tp),
                "direction_from_deg": num(np.degrees(self.direction)
                                          if isinstance(self.direction, np.ndarray)
                                          else math.degrees(self.direction)),
                "spectrum": self.spectrum, "gamma": self.gamma}


#: Columns of a component array: angular frequency [rad/s], amplitude [m], wavenumber [rad/m],
#: phase [rad].
COMP_OMEGA, COMP_AMP, COMP_K, COMP_PHASE = range(4)


def wave_components(sea: SeaState, *, n_components: int = 128, seed: int = 0,
                    n_batch: int = 1, length: float | None = None,
                    streams: Any = None) -> np.ndarray:
    """A seeded realisation of ``sea``: array (n_batch, n_components, 4) of (omega [rad/s],
    amplitude [m], wavenumber [rad/m], phase [rad]) per component (module docstring), one
    frequency in each of ``n_components`` bins of equal log-width (fine near the peak, coarse in
    the tail). Band: all but 0.1 % (low) and 0.5 % (high) of the elevation's energy; with the
    vessel ``length`` [m] given, the high end is raised to cover 99.5 % of the heading
    response too (:func:`first_order_response` at 45 deg off the bow: the heading follows the
    wave slope, whose spectrum decays only like 1/omega until the hull length filters it).
    Lane b draws from ``default_rng([seed, b])``, independent of ``n_batch`` (or from
    ``default_rng([seed, streams[b]])`` when ``streams`` gives each lane its stream).

    A batch of sea states (:attr:`SeaState.batch` B; ``n_batch`` 1 or B) gives lane b the
    realisation of its own sea state, with the same draws: the band of each distinct T_p from
    the unit spectrum (:meth:`SeaState.unit`, the same numbers as :meth:`SeaState.band` and the
    heading band to rounding), the amplitudes from lane b's H_s and T_p."""
    B = sea.batch
    if B is not None:
        if n_batch not in (1, B):
            raise UsvidError(f"wave components: a batch of {B} sea states for n_batch "
                             f"{n_batch}")
        n_batch = B
    lo, hi = sea.band()
    if length is not None:
        if not (isinstance(length, (int, float)) and math.isfinite(length) and length > 0):
            raise UsvidError(f"wave components: length must be > 0 m (got {length!r})")
        if B is None:
            psi = sea.chi - math.pi / 4.0

            def yaw_spectrum(w: np.ndarray) -> np.ndarray:
                return first_order_response(w, sea, float(length), psi)[2] * sea.density(w)

            hi = max(hi, energy_band(yaw_spectrum, sea.omega_p)[1])
        else:
            hi = np.maximum(hi, _per_period(sea, lambda w1, s1, tps: _yaw_high(
                w1, s1, tps, float(length), _HIGH_TAIL)))
    w, a, ph = components(sea.density, lo, hi, n_components, seed, n_batch, log=True,
                          streams=streams)
    return np.ascontiguousarray(np.stack([w, a, w * w / G, ph], axis=-1))


#: The high tail left out of a realisation's band (:func:`usvid.models.environment._spectral.
#: energy_band`'s default).
_HIGH_TAIL = 5e-3
#: Points of the spectral integrals (band, drift) from omega_p / 20 to 20 omega_p.
_GRID = 20_001


def _per_period(sea: SeaState, f: Any) -> np.ndarray:
    """``f(w1, s1, tps, out)`` of the unit spectrum S_1 = ``s1`` on ``w1`` (:data:`_GRID` points
    from omega_p / 20 to 20 omega_p of T_p = 1 s, :meth:`SeaState.unit`) for each distinct T_p
    of the batch ``tps`` [s] -> (B,) values, one per run (the quantities that depend on the
    spectrum's shape through T_p only: the heading band, the drift integral)."""
    unit = sea.unit()
    w1 = np.geomspace(unit.omega_p / 20.0, unit.omega_p * 20.0, _GRID)
    s1 = unit.density(w1)
    tp = np.broadcast_to(np.asarray(sea.tp, dtype=float), (int(sea.batch or 1),))
    distinct, which = np.unique(tp, return_inverse=True)
    return np.asarray(f(w1, s1, distinct), dtype=float)[which.reshape(-1)]


@numba.njit(cache=True)
def _yaw_band_kernel(w1, s1, tps, length, high_tail, out):
    """The high end [rad/s] of the heading response's energy band (all but ``high_tail``) for
    each peak period tps[j] [s]: the spectrum S(w) = H_s^2 T_p S_1(w T_p) on the grid w1 / T_p
    times |H_psi|^2 at 45 deg off the bow (:func:`first_order_response`), integrated by the
    trapezoid rule and interpolated as :func:`usvid.models.environment._spectral.energy_band`
    (the constant factors cancel in the normalised cumulative)."""
    n = w1.shape[0]
    cb = math.cos(math.pi / 4.0)
    sb = math.sin(math.pi / 4.0)
    cum = np.empty(n)
    for j in range(tps.shape[0]):
        tp = tps[j]
        prev = 0.0
        for i in range(n):
            w = w1[i] / tp
            k = w * w / G
            f0, f1 = _length_factors(k, length, cb)
            h = k * sb * cb * f1
            y = h * h * s1[i]
            cum[i] = 0.0 if i == 0 else cum[i - 1] + 0.5 * (y + prev) * (w1[i] - w1[i - 1])
            prev = y
        target = (1.0 - high_tail) * cum[n - 1]
        lo, hi = 0, n - 1  # the last point with cum <= target
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if cum[mid] <= target:
                lo = mid
            else:
                hi = mid
        d = cum[lo + 1] - cum[lo]
        frac = (target - cum[lo]) / d if d > 0 else 0.0
        out[j] = (w1[lo] + frac * (w1[lo + 1] - w1[lo])) / tp


def _yaw_high(w1: np.ndarray, s1: np.ndarray, tps: np.ndarray, length: float,
              high_tail: float) -> np.ndarray:
    out = np.empty(tps.size)
    _yaw_band_kernel(w1, s1, np.ascontiguousarray(tps), length, high_tail, out)
    return out


@numba.njit(cache=True)
def _drift_kernel(w1, s1, tps, draft, out):
    """int S_1(w1) (1 - exp(-2 k d)) dw1 with k = (w1 / T_p)^2 / g for each T_p = tps[j] [s]
    (trapezoid rule): the drift integral of :func:`drift_coefficients` per m^2 of H_s^2."""
    n = w1.shape[0]
    for j in range(tps.shape[0]):
        tp = tps[j]
        acc = 0.0
        prev = 0.0
        for i in range(n):
            w = w1[i] / tp
            f = s1[i] * (1.0 - math.exp(-2.0 * (w * w / G) * draft))
            if i > 0:
                acc += 0.5 * (f + prev) * (w1[i] - w1[i - 1])
            prev = f
        out[j] = acc


# ---------------------------------------------------------------------------------------------
# one sample (numba) - the one place of the formulas
# ---------------------------------------------------------------------------------------------
@numba.njit(cache=True)
def _length_factors(k, length, cos_beta):
    """(f0, f1) of a component of wavenumber ``k`` [rad/m] over the hull ``length`` [m]:
    f0 = sin h / h (mean of the displacement), f1 = 3 (sin h - h cos h) / h^3 (its slope), with
    h = k L cos(beta) / 2 (series near h = 0)."""
    h = 0.5 * k * length * cos_beta
    if abs(h) < 1e-2:
        h2 = h * h
        return 1.0 - h2 / 6.0, 1.0 - h2 / 10.0 + h2 * h2 / 280.0
    sh, ch = math.sin(h), math.cos(h)
    return sh / h, 3.0 * (sh - h * ch) / (h * h * h)


@numba.njit(cache=True)
def _phase(comp, cx, sx, t, x, y):
    """theta = k (x cos chi + y sin chi) - omega t + phi of one component row."""
    return comp[2] * (x * cx + y * sx) - comp[0] * t + comp[3]


@numba.njit(cache=True)
def _contributions(a, k, f0, f1, sb, cb, c, s):
    """One component's (zeta, xi, psi_w) for cos/sin of its phase ``c``, ``s``: a cos theta,
    -a f0 sin theta (displacement along the direction of travel), -k a sin(beta) cos(beta) f1
    cos theta (heading)."""
    return a * c, -a * f0 * s, -k * a * sb * cb * f1 * c


@numba.njit(cache=True)
def wave_elevation_scalar(comps, chi, t, x, y):
    """Wave elevation zeta [m] at time ``t`` [s] and point ``x``, ``y`` [m, NED] of one lane's
    components ``comps`` (n, 4), waves travelling towards ``chi`` [rad]."""
    cx, sx = math.cos(chi), math.sin(chi)
    z = 0.0
    for i in range(comps.shape[0]):
        z += comps[i, 1] * math.cos(_phase(comps[i], cx, sx, t, x, y))
    return z


@numba.njit(cache=True)
def wave_motion_scalar(comps, chi, length, t, x, y, psi):
    """First-order wave-induced motion of a vessel of ``length`` [m] at ``x``, ``y`` [m, NED],
    heading ``psi`` [rad], time ``t`` [s]: (zeta [m] the elevation there, north [m], east [m]
    displacement, psi_w [rad] heading), for one lane's ``comps`` (n, 4), waves travelling
    towards ``chi`` [rad] (module docstring)."""
    cx, sx = math.cos(chi), math.sin(chi)
    beta = chi - psi
    cb, sb = math.cos(beta), math.sin(beta)
    z = 0.0
    xi = 0.0
    yaw = 0.0
    for i in range(comps.shape[0]):
        k = comps[i, 2]
        f0, f1 = _length_factors(k, length, cb)
        th = _phase(comps[i], cx, sx, t, x, y)
        dz, dxi, dyaw = _contributions(comps[i, 1], k, f0, f1, sb, cb, math.cos(th),
                                       math.sin(th))
        z += dz
        xi += dxi
        yaw += dyaw
    return z, xi * cx, xi * sx, yaw


@numba.njit(cache=True)
def mean_drift_scalar(fx0, fy0, chi, psi):
    """Mean wave drift force (X, Y) [N, body] of :func:`drift_coefficients`' ``fx0``, ``fy0``
    [N] at heading ``psi`` [rad], waves travelling towards ``chi`` [rad]
    (:func:`mean_drift_cs`)."""
    return mean_drift_cs(fx0, fy0, math.cos(chi), math.sin(chi), math.cos(psi), math.sin(psi))


@numba.njit(cache=True, error_model="numpy", forceinline=True)
def mean_drift_cs(fx0, fy0, cchi, schi, cpsi, spsi):
    """:func:`mean_drift_scalar` from the cosines and sines of the wave direction chi and the
    heading psi: with the relative angle beta = chi - psi, (X, Y) = (fx0 cos beta |cos beta|,
    fy0 sin beta |sin beta|). No library call: the integration core's vector step calls it."""
    cb = cchi * cpsi + schi * spsi
    sb = schi * cpsi - cchi * spsi
    return fx0 * cb * abs(cb), fy0 * sb * abs(sb)


#: fast-math flags of the batch sums: reassociation (vectorised sums over components) and FMA;
#: NaN/inf semantics kept
_FM = {"nsz", "arcp", "contract", "reassoc"}


@numba.njit(cache=True, fastmath=_FM)
def _motion_batch(chis, comps, length, t, x, y, psi, out, elevation_only):
    """The sums of :func:`wave_motion_scalar` over lanes and times, lane b's waves travelling
    towards chis[b] [rad]. A lane that stays at one
    point and heading on a uniform time grid (the usual case of an analysis) rotates each
    component's phasor by its exact step exp(-i omega dt) per sample and keeps its length
    factors: the same sum, with a few multiplications instead of the library's sin and cos."""
    nb, nt, nc = out.shape[1], out.shape[2], comps.shape[1]
    uniform = nt > 1
    dt = t[1] - t[0] if nt > 1 else 0.0
    for j in range(1, nt):
        if abs((t[j] - t[j - 1]) - dt) > 1e-9 * max(1.0, abs(dt)):
            uniform = False
    c = np.empty(nc)
    s = np.empty(nc)
    cd = np.empty(nc)
    sd = np.empty(nc)
    gz = np.empty(nc)
    gxi = np.empty(nc)
    gyaw = np.empty(nc)
    for b in range(nb):
        chi = chis[b]
        cx, sx = math.cos(chi), math.sin(chi)
        fixed = uniform
        for j in range(1, nt):
            if x[b, j] != x[b, 0] or y[b, j] != y[b, 0] or psi[b, j] != psi[b, 0]:
                fixed = False
                break
        if fixed:
            beta = chi - psi[b, 0]
            cb, sb = math.cos(beta), math.sin(beta)
            for i in range(nc):
                comp = comps[b, i]
                th = _phase(comp, cx, sx, t[0], x[b, 0], y[b, 0])
                c[i], s[i] = math.cos(th), math.sin(th)
                cd[i], sd[i] = math.cos(comp[0] * dt), math.sin(comp[0] * dt)
                f0, f1 = _length_factors(comp[2], length, cb)
                # the factors of (cos theta, sin theta) in each output
                gz[i], gxi[i], gyaw[i] = _contributions(comp[1], comp[2], f0, f1, sb, cb, 1.0,
                                                        1.0)
            for j in range(nt):
                z = 0.0
                xi = 0.0
                yaw = 0.0
                if elevation_only:
                    for i in range(nc):
                        z += gz[i] * c[i]
                else:
                    for i in range(nc):
                        z += gz[i] * c[i]
                        xi += gxi[i] * s[i]
                        yaw += gyaw[i] * c[i]
                for i in range(nc):  # theta decreases by omega dt
                    ci = c[i]
                    c[i] = ci * cd[i] + s[i] * sd[i]
                    s[i] = s[i] * cd[i] - ci * sd[i]
                out[0, b, j] = z
                if not elevation_only:
                    out[1, b, j] = xi * cx
                    out[2, b, j] = xi * sx
                    out[3, b, j] = yaw
            continue
        for j in range(nt):
            if elevation_only:
                out[0, b, j] = wave_elevation_scalar(comps[b], chi, t[j], x[b, j], y[b, j])
            else:
                z, n, e, w = wave_motion_scalar(comps[b], chi, length, t[j], x[b, j], y[b, j],
                                                psi[b, j])
                out[0, b, j] = z
                out[1, b, j] = n
                out[2, b, j] = e
                out[3, b, j] = w


# ---------------------------------------------------------------------------------------------
# array API
# ---------------------------------------------------------------------------------------------
def _lanes(comps: np.ndarray, t: Any, *tracks: Any) -> tuple[np.ndarray, ...]:
    comps = np.ascontiguousarray(comps, dtype=float)
    if comps.ndim != 3 or comps.shape[2] != 4:
        raise UsvidError(f"wave components must have shape (n_batch, n, 4) (got {comps.shape})")
    t = np.ascontiguousarray(np.atleast_1d(np.asarray(t, dtype=float)))
    if t.ndim != 1:
        raise UsvidError(f"t must be 1-D [s] (got shape {t.shape})")
    shape = (comps.shape[0], t.size)
    out = [np.ascontiguousarray(np.broadcast_to(np.asarray(a, dtype=float), shape))
           for a in tracks]
    return (comps, t, *out)


def _chis(sea: SeaState, nb: int) -> np.ndarray:
    """The direction of travel chi [rad] of each of ``nb`` lanes: a batch of sea states has one
    per lane (UsvidError when its size is not ``nb``)."""
    if sea.batch is not None and sea.batch != nb:
        raise UsvidError(f"wave components of {nb} lanes for a batch of {sea.batch} sea states")
    return np.ascontiguousarray(np.broadcast_to(np.asarray(sea.chi, dtype=float), (nb,)))


def wave_elevation(comps: np.ndarray, sea: SeaState, t: Any, x: Any = 0.0, y: Any = 0.0
                   ) -> np.ndarray:
    """Elevation zeta [m], shape (n_batch, n_t), of the components ``comps``
    (:func:`wave_components`) of ``sea`` at times ``t`` [s] and points ``x``, ``y`` [m, NED]
    (scalars, (n_t,) or (n_batch, n_t))."""
    comps, t, x, y = _lanes(comps, t, x, y)
    out = np.empty((1, comps.shape[0], t.size))
    _motion_batch(_chis(sea, comps.shape[0]), comps, 1.0, t, x, y, x, out, True)
    return out[0]


@dataclass
class WaveMotion:
    """First-order wave-induced motion (n_batch, n_t): ``zeta`` [m] the elevation at the vessel,
    ``north``, ``east`` [m] the displacement, ``psi`` [rad] the heading."""

    zeta: np.ndarray
    north: np.ndarray
    east: np.ndarray
    psi: np.ndarray


def wave_motion(comps: np.ndarray, sea: SeaState, length: float, t: Any, x: Any = 0.0,
                y: Any = 0.0, psi: Any = 0.0) -> WaveMotion:
    """First-order wave-induced motion of a vessel of ``length`` [m] along the track ``x``, ``y``
    [m, NED], ``psi`` [rad] (scalars, (n_t,) or (n_batch, n_t)) at times ``t`` [s]; the same code
    as :func:`wave_motion_scalar`."""
    if not (isinstance(length, (int, float)) and math.isfinite(length) and length > 0):
        raise UsvidError(f"wave motion: length must be > 0 m (got {length!r})")
    comps, t, x, y, psi = _lanes(comps, t, x, y, psi)
    out = np.empty((4, comps.shape[0], t.size))
    _motion_batch(_chis(sea, comps.shape[0]), comps, float(length), t, x, y, psi, out, False)
    return WaveMotion(out[0], out[1], out[2], out[3])


def first_order_response(omega: Any, sea: SeaState, length: float, psi: float
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """|H|^2 of the first-order response at fixed heading ``psi`` [rad] and position, per unit
    wave amplitude: (north [m^2/m^2], east [m^2/m^2], heading [rad^2/m^2]) at ``omega`` [rad/s];
    times S(omega) they are the motion spectra (module docstring; the factors of
    :func:`wave_motion_scalar`). One sea state (:meth:`SeaState.lane` of a batch)."""
    if sea.batch is not None:
        raise UsvidError("first-order response: one sea state (sea.lane(b) of a batch)")
    w = np.ascontiguousarray(np.asarray(omega, dtype=float).ravel())
    out = np.empty((3, w.size))
    _response_batch(w, sea.chi, float(length), float(psi), out)
    shape = np.shape(omega)
    return out[0].reshape(shape), out[1].reshape(shape), out[2].reshape(shape)


@numba.njit(cache=True)
def _response_batch(w, chi, length, psi, out):
    beta = chi - psi
    cb, sb = math.cos(beta), math.sin(beta)
    for i in range(w.shape[0]):
        k = w[i] * w[i] / G
        f0, f1 = _length_factors(k, length, cb)
        dz, dxi, dyaw = _contributions(1.0, k, f0, f1, sb, cb, 1.0, 1.0)
        out[0, i] = (dxi * math.cos(chi)) ** 2
        out[1, i] = (dxi * math.sin(chi)) ** 2
        out[2, i] = dyaw * dyaw


def drift_coefficients(sea: SeaState, length: float, beam: float, draft: float, *,
                       rho: float = RHO_WATER) -> tuple[Any, Any]:
    """(fx0, fy0) [N]: ``rho g B I`` and ``rho g L I`` with ``I = int S(w) (1 - exp(-2 k d))
    dw`` [m^2] (module docstring); :func:`mean_drift_scalar` turns them into the force at a
    heading. ``length``, ``beam``, ``draft`` [m], ``rho`` [kg/m^3]. A batch of sea states gives
    (B,) arrays: ``I = H_s^2 int S_1(w1) (1 - exp(-2 k d)) dw1`` over the unit spectrum
    (:meth:`SeaState.unit`) once per distinct T_p, the same integral to rounding."""
    for name, v in (("length", length), ("beam", beam), ("draft", draft), ("rho", rho)):
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise UsvidError(f"wave drift: {name} must be > 0 (got {v!r})")
    if sea.batch is not None:
        def kernel(w1: np.ndarray, s1: np.ndarray, tps: np.ndarray) -> np.ndarray:
            out = np.empty(tps.size)
            _drift_kernel(w1, s1, np.ascontiguousarray(tps), float(draft), out)
            return out
        integral = np.asarray(sea.hs, dtype=float) ** 2 * _per_period(sea, kernel)
        return rho * G * beam * integral, rho * G * length * integral
    w = np.geomspace(sea.omega_p / 20.0, sea.omega_p * 20.0, _GRID)
    f = sea.density(w) * (1.0 - np.exp(-2.0 * (w * w / G) * draft))
    integral = float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(w)))
    return rho * G * beam * integral, rho * G * length * integral


def mean_drift_force(sea: SeaState, length: float, beam: float, draft: float, psi: Any, *,
                     rho: float = RHO_WATER) -> tuple[np.ndarray, np.ndarray]:
    """Mean wave drift force (X, Y) [N, body frame] on a hull ``length`` x ``beam`` [m] of
    ``draft`` [m] at heading ``psi`` [rad] (array) in ``sea`` (module docstring)."""
    fx0, fy0 = drift_coefficients(sea, length, beam, draft, rho=rho)
    beta = sea.chi - np.asarray(psi, dtype=float)
    cb, sb = np.cos(beta), np.sin(beta)
    return fx0 * cb * np.abs(cb), fy0 * sb * np.abs(sb)
