"""Chaotic genetic algorithm (CGA) for bounded global minimisation (Ma et al.).

Ma et al. ("Identification process" and "Identification results") identifies the turning-diameter
model with a chaotic genetic algorithm configured as: population 100, 1000 generations, crossover
probability 0.8, mutation probability 0.02, coding precision 4 (decimal places), 100 chaotic
iterations, chaotic population 10 % of the genetic population, roulette selection, single-point
crossover, real coding. The paper gives no further detail; usvid reads it as follows (each step is
vectorised over the population; one generation is a handful of numpy calls):

* **Chaos** is the logistic map ``c_{k+1} = 4 c_k (1 - c_k)`` on (0, 1) (fully chaotic at
  mu = 4); a value is mapped into the bounds as ``lo + c (hi - lo)``. States that fall onto the
  map's fixed/absorbing points (0, 0.75, 1) are re-seeded from the numpy Generator.
* **Initial population**: 100 chaotic vectors (one logistic orbit per gene, seeded from ``seed``).
* **Fitness** for roulette selection: ``1 / (F + 1e-12)`` (F the objective to minimise);
  non-finite objectives are replaced by a large penalty.
* **Selection**: roulette wheel (probability proportional to fitness), plus elitism: the best
  individual is carried unchanged into the next generation (standard, not stated in the paper).
* **Crossover**: consecutive pairs of the selected population are crossed with probability 0.8 at
  one random cut point (genes after the cut swapped).
* **Mutation**: each gene, with probability 0.02, is replaced by a uniform value within bounds.
* **Chaotic search** (the "chaotic population"): the best 10 % of the individuals each explore
  100 chaotic points ``x + rho_g (2 c - 1) (hi - lo)`` (clipped to the bounds) with a radius
  ``rho_g`` shrinking geometrically from 0.1 to 1e-4 over the generations; each keeps its best
  point, and these 10 points replace the 10 worst individuals.
* **Coding precision 4**: genes are rounded to 4 decimal places.

All randomness comes from one ``numpy.random.Generator(seed)``: a run is reproducible.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numba import njit

import usvid.jitcache  # noqa: F401 - numba's cache written best effort
from usvid.errors import IdentificationError

PENALTY = 1e12


@njit(cache=True)
def _logistic_orbit(c0, n):  # pragma: no cover - numba
    """n iterates of the logistic map c <- 4 c (1 - c) from state c0 (any shape); (n,) + shape."""
    flat = c0.ravel().copy()
    out = np.empty((n, flat.size))
    for k in range(n):
        for i in range(flat.size):
            flat[i] = 4.0 * flat[i] * (1.0 - flat[i])
        out[k] = flat
    return out


def _fix_degenerate(c: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    bad = (c < 1e-9) | (c > 1 - 1e-9) | (np.abs(c - 0.75) < 1e-9)
    if bad.any():
        c = c.copy()
        c[bad] = rng.uniform(0.01, 0.99, size=int(bad.sum()))
    return c


@dataclass
class CGAResult:
    """Outcome of :func:`cga`.

    x: best parameter vector (p,); fun: its objective; history: best objective after each
    generation (G,); n_evaluations: objective evaluations (rows); seed and settings as used.
    """

    x: np.ndarray
    fun: float
    history: np.ndarray
    n_evaluations: int
    seed: int
    settings: dict[str, Any] = field(default_factory=dict)


def cga(objective: Callable[[np.ndarray], np.ndarray], bounds: Sequence[tuple[float, float]], *,
        pop_size: int = 100, generations: int = 1000, p_crossover: float = 0.8,
        p_mutation: float = 0.02, chaos_iterations: int = 100, chaos_share: float = 0.10,
        precision: int | None = 4, rho_start: float = 0.1, rho_end: float = 1e-4,
        seed: int = 0) -> CGAResult:
    """Minimise ``objective`` within ``bounds`` by the chaotic genetic algorithm (Ma et al.).

    Parameters
    ----------
    objective : callable
        Vectorised objective: takes an (M, p) array of candidates, returns (M,) values.
    bounds : sequence of (lo, hi)
        One pair per parameter (Ma et al.'s bounds for the turning-diameter model are
        :data:`usvid.identify.turning_diameter.MA_BOUNDS`).
    pop_size, generations, p_crossover, p_mutation, chaos_iterations, chaos_share, precision
        Ma et al.'s settings by default (see the module docstring for how each is used).
    rho_start, rho_end : float
        Chaotic-search radius (fraction of the bound width) at the first and last generation.
    seed : int
        Seed of the numpy Generator (every random choice, including the chaotic initial states).
    """
    b = np.asarray(bounds, dtype=float)
    if b.ndim != 2 or b.shape[1] != 2 or b.shape[0] == 0:
        raise IdentificationError(f"cga: `bounds` must be a sequence of (lo, hi) pairs "
                                  f"(got shape {b.shape})")
    lo, hi = b[:, 0], b[:, 1]
    if not np.all(np.isfinite(b)) or np.any(hi <= lo):
        raise IdentificationError("cga: every bound must be finite with lo < hi")
    if pop_size < 4 or generations < 1 or chaos_iterations < 1:
        raise IdentificationError("cga: need pop_size >= 4, generations >= 1, "
                                  "chaos_iterations >= 1")
    for nm, v in (("p_crossover", p_crossover), ("p_mutation", p_mutation),
                  ("chaos_share", chaos_share)):
        if not 0 <= v <= 1:
            raise IdentificationError(f"cga: `{nm}` must be in [0, 1] (got {v!r})")
    rng = np.random.default_rng(seed)
    p = lo.size
    width = hi - lo
    n_chaos = max(1, int(round(chaos_share * pop_size)))
    n_eval = 0

    def evaluate(x: np.ndarray) -> np.ndarray:
        nonlocal n_eval
        n_eval += x.shape[0]
        with np.errstate(all="ignore"):
            f = np.asarray(objective(x), dtype=float)
        return np.where(np.isfinite(f), f, PENALTY)

    def quantise(x: np.ndarray) -> np.ndarray:
        if precision is not None:
            x = np.round(x, precision)
        return np.clip(x, lo, hi)

    # chaotic initial population: one logistic orbit per gene
    c = _fix_degenerate(rng.uniform(0.01, 0.99, size=p), rng)
    orbit = _logistic_orbit(c, pop_size)
    pop = quantise(lo + orbit * width)
    fit = evaluate(pop)
    chaos_state = _fix_degenerate(rng.uniform(0.01, 0.99, size=(n_chaos, p)), rng)
    history = np.empty(generations)
    ratio = (rho_end / rho_start) ** (1.0 / max(generations - 1, 1))
    half = pop_size // 2
    for g in range(generations):
        ib = int(np.argmin(fit))
        elite, elite_f = pop[ib].copy(), fit[ib]
        # roulette selection
        w = 1.0 / (fit + 1e-12)
        idx = rng.choice(pop_size, size=pop_size, p=w / w.sum())
        new = pop[idx].copy()
        # single-point crossover of consecutive pairs
        if p > 1:
            cross = rng.random(half) < p_crossover
            cut = rng.integers(1, p, size=half)
            swap = (np.arange(p)[None, :] >= cut[:, None]) & cross[:, None]
            a, bb = new[0:2 * half:2], new[1:2 * half:2]
            a2 = np.where(swap, bb, a)
            b2 = np.where(swap, a, bb)
            new[0:2 * half:2], new[1:2 * half:2] = a2, b2
        # mutation
        mut = rng.random(new.shape) < p_mutation
        if mut.any():
            new[mut] = (lo + rng.random(new.shape) * width)[mut]
        new = quantise(new)
        new_f = evaluate(new)
        # elitism
        iw = int(np.argmax(new_f))
        new[iw], new_f[iw] = elite, elite_f
        # chaotic search around the best n_chaos individuals
        order = np.argsort(new_f)
        best_idx = order[:n_chaos]
        rho = rho_start * ratio**g
        orbit = _logistic_orbit(chaos_state, chaos_iterations).reshape(
            chaos_iterations, n_chaos, p)
        chaos_state = _fix_degenerate(orbit[-1], rng)
        cand = quantise(new[best_idx][None] + rho * (2 * orbit - 1) * width)
        cf = evaluate(cand.reshape(-1, p)).reshape(chaos_iterations, n_chaos)
        kbest = np.argmin(cf, axis=0)
        cx = cand[kbest, np.arange(n_chaos)]
        cfx = cf[kbest, np.arange(n_chaos)]
        worst = order[::-1][:n_chaos]
        new[worst], new_f[worst] = cx, cfx
        pop, fit = new, new_f
        history[g] = float(np.min(fit))
    ib = int(np.argmin(fit))
    return CGAResult(
        x=pop[ib].copy(), fun=float(fit[ib]), history=history, n_evaluations=n_eval, seed=seed,
        settings={"pop_size": pop_size, "generations": generations, "p_crossover": p_crossover,
                  "p_mutation": p_mutation, "chaos_iterations": chaos_iterations,
                  "chaos_share": chaos_share, "precision": precision, "rho_start": rho_start,
                  "rho_end": rho_end})
