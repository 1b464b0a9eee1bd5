"""Random-phase realisation of a one-sided spectrum (shared by waves and gusts).

A stationary Gaussian process with the one-sided spectrum S is approximated by a sum of
harmonic components (the "deterministic spectral amplitude" method; Tucker, Challenor & Carter
1984, Applied Ocean Research 6, 118-122; Fossen 2021, ch. 10.2):

    x(t) = sum_k a_k cos(w_k t + phi_k),  a_k = sqrt(2 S(w_k) dw_k),  phi_k ~ U(0, 2 pi),

with each frequency drawn uniformly inside its own bin of width dw_k, so that the frequencies are
not commensurate and the record does not repeat (a sum over an equally spaced grid repeats
after 2 pi / dw). Lane b of a batch draws from ``numpy.random.default_rng([seed, b])``: a lane's
realisation does not depend on the batch size.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numba
import numpy as np

import usvid.jitcache  # noqa: F401 - numba's cache written best effort
from usvid.errors import UsvidError


def lane_rngs(seed: int, n_batch: int, streams: Any = None) -> list[np.random.Generator]:
    """One generator per lane: ``default_rng([seed, b])`` for b = 0 .. n_batch - 1, or
    ``default_rng([seed, streams[b]])`` when ``streams`` (n_batch whole numbers >= 0) is given
    (run i of a study cut into batches draws from (seed, i) whatever its batch)."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise UsvidError(f"seed must be an integer >= 0 (got {seed!r})")
    if isinstance(n_batch, bool) or not isinstance(n_batch, (int, np.integer)) or n_batch < 1:
        raise UsvidError(f"n_batch must be an integer >= 1 (got {n_batch!r})")
    if streams is None:
        return [np.random.default_rng([int(seed), b]) for b in range(int(n_batch))]
    st = np.asarray(streams, dtype=float).reshape(-1)
    if st.size != int(n_batch) or not np.all(np.isfinite(st)) or np.any(st < 0) \
            or np.any(st != np.floor(st)):
        raise UsvidError(f"streams must be {int(n_batch)} whole numbers >= 0 (got {st.size} "
                         "values)")
    return [np.random.default_rng([int(seed), int(b)]) for b in st]


def components(spectrum: Callable[[np.ndarray], np.ndarray], lo: Any, hi: Any, n: int,
               seed: int, n_batch: int, *, log: bool = False, streams: Any = None
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(freq, amp, phase), each (n_batch, n): ``n`` components of ``spectrum`` between ``lo``
    and ``hi`` (frequency units of the spectrum, > 0; numbers, or (n_batch,) arrays: a band
    per lane), bins equal in width (``log=False``) or in log-width (``log=True``, for spectra
    spanning decades), one frequency uniform inside each bin, ``amp = sqrt(2 S(freq) width)``
    (``spectrum`` of the (n_batch, n) frequencies, lane first), phase uniform in [0, 2 pi);
    lane b from :func:`lane_rngs` (``streams``: its stream indices)."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 1:
        raise UsvidError(f"n_components must be an integer >= 1 (got {n!r})")
    lo_a, hi_a = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    if not (np.all(np.isfinite(lo_a)) and np.all(np.isfinite(hi_a)) and np.all(0 < lo_a)
            and np.all(lo_a < hi_a)):
        raise UsvidError(f"frequency band must satisfy 0 < lo < hi (got {lo!r}, {hi!r})")
    if lo_a.ndim == 0 and hi_a.ndim == 0:
        edges = np.geomspace(lo, hi, n + 1) if log else np.linspace(lo, hi, n + 1)
    else:  # a band per lane: (n_batch, n + 1) edges
        lo_a, hi_a = (np.broadcast_to(a, (n_batch,)) for a in (lo_a, hi_a))
        edges = (np.geomspace(lo_a, hi_a, n + 1, axis=-1) if log
                 else np.linspace(lo_a, hi_a, n + 1, axis=-1))
    width = np.diff(edges, axis=-1)
    w2 = np.broadcast_to(width, (n_batch, n))
    e2 = np.broadcast_to(edges[..., :-1], (n_batch, n))
    freq = np.empty((n_batch, n))
    phase = np.empty((n_batch, n))
    for b, rng in enumerate(lane_rngs(seed, n_batch, streams)):
        u = rng.random((2, n))
        freq[b] = e2[b] + u[0] * w2[b]
        phase[b] = 2.0 * np.pi * u[1]
    amp = np.sqrt(2.0 * np.maximum(spectrum(freq), 0.0) * width)
    return freq, amp, phase


def energy_band(spectrum: Callable[[np.ndarray], np.ndarray], peak: float, *,
                low_tail: float = 1e-3, high_tail: float = 5e-3) -> tuple[float, float]:
    """The band [lo, hi] outside which the spectrum holds ``low_tail`` and ``high_tail`` of its
    energy (numerical cumulative integral on 20 000 log-spaced points from peak / 20 to 20
    peak), for a spectrum with its peak at ``peak``."""
    w = np.geomspace(peak / 20.0, peak * 20.0, 20_001)
    s = spectrum(w)
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (s[1:] + s[:-1]) * np.diff(w))])
    cum /= cum[-1]
    return float(np.interp(low_tail, cum, w)), float(np.interp(1.0 - high_tail, cum, w))


@numba.njit(cache=True, fastmath={"nsz", "arcp", "contract", "reassoc"})
def sum_cos(omega, amp, phase, t, out):
    """out[b, j] += sum_k amp[b, k] cos(omega[b, k] t[j] + phase[b, k]) (omega [rad/s], t [s]).
    On a uniform grid each component's phasor is rotated by its exact step exp(i omega dt) per
    sample (the same sum: a few multiplications instead of a cosine); else cosines."""
    nb, nc, nt = omega.shape[0], omega.shape[1], t.shape[0]
    dt = t[1] - t[0] if nt > 1 else 0.0
    uniform = True
    for j in range(1, nt):
        if abs((t[j] - t[j - 1]) - dt) > 1e-9 * max(1.0, abs(dt)):
            uniform = False
    c = np.empty(nc)
    s = np.empty(nc)
    cd = np.empty(nc)
    sd = np.empty(nc)
    for b in range(nb):
        if not uniform:
            for j in range(nt):
                acc = 0.0
                for i in range(nc):
                    acc += amp[b, i] * math.cos(omega[b, i] * t[j] + phase[b, i])
                out[b, j] += acc
            continue
        for i in range(nc):
            th = omega[b, i] * t[0] + phase[b, i]
            c[i], s[i] = math.cos(th), math.sin(th)
            cd[i], sd[i] = math.cos(omega[b, i] * dt), math.sin(omega[b, i] * dt)
        for j in range(nt):
            acc = 0.0
            for i in range(nc):
                acc += amp[b, i] * c[i]
            for i in range(nc):
                ci = c[i]
                c[i] = ci * cd[i] - s[i] * sd[i]
                s[i] = s[i] * cd[i] + ci * sd[i]
            out[b, j] += acc
