"""The parameter uncertainty of a model and the one sampler of it.

:meth:`Uncertainty.from_model` reads a model's stored uncertainty (the one reader of the model
file's ``identification.covariance`` and ``identification.std_errors``): the covariance of the
fitted parameters when the model has one, else independent normals from the standard errors,
optionally completed with an assumed relative standard deviation for fitted parameters without
one. :meth:`Uncertainty.sample` turns it (and further independent distributions,
:class:`Distribution`) into parameter sets. Every user of parameter samples draws them here:
``usvid montecarlo`` (:mod:`usvid.scale.montecarlo`), the autopilot's robustness
(:mod:`usvid.control.robustness`) and the report's prediction bands
(:func:`usvid.identify.validation.replay_band`).

Sampling (seeded in blocks): runs are drawn in fixed blocks of :data:`BLOCK` runs, block k from
the generator seeded with ``(seed, k)``; run i's parameters are the same whatever range of
runs is asked for (the chunking of a Monte-Carlo run or the number of its workers). Jointly
normal parameters are ``mean + L z`` with ``C = L L^T`` (Cholesky, or the eigen-decomposition
of a semi-definite C), z standard normal.

Bounds policy: a draw outside the bounds of the model's parameters (``T > 0``, masses > 0, ...:
the kind's declared ``gt``/``ge``/``lt``/``le``) is drawn again from the same block's stream
(every parameter of that run, jointly), at most :data:`MAX_REDRAWS` times; a run with no draw
within the bounds after that is marked failed (:attr:`Sample.failed`), never an error that
stops the other runs. :class:`Sample` counts both: ``redrawn`` (runs drawn more than once that
ended within the bounds) and ``n_failed``.

Units: the parameters' own SI units.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from usvid.errors import UsvidError

__all__ = ["BLOCK", "MAX_REDRAWS", "Distribution", "Sample", "Uncertainty", "lane_errors",
           "redraw_invalid"]

#: Runs per sampling block (the unit of the seeded random streams).
BLOCK = 1024
#: Largest number of times a run's draw is repeated to bring it within the parameter bounds.
MAX_REDRAWS = 100



def redraw_invalid(n: int, invalid: Callable[[np.ndarray], np.ndarray],
                   draw_again: Callable[[np.ndarray], None]) -> tuple[np.ndarray, np.ndarray]:
    """The bounds policy of a block of ``n`` draws (module docstring): the rows whose draw is
    invalid (``invalid(rows)``: a mask over ``rows``) are drawn again (``draw_again(rows)``,
    from the block's own generator) until valid, at most :data:`MAX_REDRAWS` times. Returns
    (n,) how often each row was drawn again and (n,) the rows still invalid (failed runs)."""
    redraws = np.zeros(n, dtype=int)
    rows = np.arange(n)
    bad = rows[invalid(rows)]
    for _ in range(MAX_REDRAWS):
        if bad.size == 0:
            break
        draw_again(bad)
        redraws[bad] += 1
        bad = bad[invalid(bad)]
    failed = np.zeros(n, dtype=bool)
    failed[bad] = True
    return redraws, failed

@dataclass(frozen=True)
class Distribution:
    """An independent distribution of one parameter: ``normal`` (a = mean, b = standard
    deviation) or ``uniform`` (a = low, b = high), SI units."""

    name: str
    dist: str
    a: float
    b: float

    def __post_init__(self) -> None:
        if self.dist not in ("normal", "uniform"):
            raise UsvidError(f"{self.name}: distribution must be normal or uniform "
                             f"(got {self.dist!r})")
        if not (math.isfinite(self.a) and math.isfinite(self.b)) or \
                (self.dist == "normal" and self.b < 0) or (self.dist == "uniform"
                                                           and self.b < self.a):
            raise UsvidError(f"{self.name}={self.dist}:{self.a:g},{self.b:g}: need finite "
                             "numbers, SD >= 0, LO <= HI")

    def draw(self, rng: np.random.Generator, n: int) -> np.ndarray:
        if self.dist == "normal":
            return self.a + self.b * rng.standard_normal(n)
        return rng.uniform(self.a, self.b, n)


@dataclass(frozen=True)
class Sample:
    """Parameter sets of runs ``lo .. hi-1``: ``values`` name -> (n,) [SI] as drawn (a failed
    run keeps its last draw), ``redraws`` (n,) how often each run was drawn again, ``failed``
    (n,) no draw within the bounds (see the module docstring)."""

    values: dict[str, np.ndarray]
    redraws: np.ndarray
    failed: np.ndarray
    mean: dict[str, float] = field(default_factory=dict)

    @property
    def redrawn(self) -> int:
        """Runs drawn more than once that ended within the bounds."""
        return int(np.sum((self.redraws > 0) & ~self.failed))

    @property
    def n_failed(self) -> int:
        return int(np.sum(self.failed))

    def usable(self, nominal: Mapping[str, float] | None = None) -> dict[str, np.ndarray]:
        """``values`` with a failed run's parameters replaced by ``nominal`` ones (default the
        means; give the model's own values, a valid parameter set, for a batch that must be
        built whole: the caller marks those runs as failed)."""
        ref = self.mean if nominal is None else nominal
        out = {}
        for n, v in self.values.items():
            v = v.copy()
            v[self.failed] = ref.get(n, math.nan)
            out[n] = v
        return out


def _bounds_mask(spec: Any, x: np.ndarray) -> np.ndarray:
    """Rows of ``x`` outside the bounds of parameter ``spec`` (or not finite)."""
    bad = ~np.isfinite(x)
    if spec is None:
        return bad
    for bound, op in ((spec.gt, np.less_equal), (spec.ge, np.less), (spec.lt, np.greater_equal),
                      (spec.le, np.greater)):
        if bound is not None:
            bad |= op(x, bound)
    return bad


@dataclass(frozen=True)
class Uncertainty:
    """Jointly normal parameters ``names`` with ``mean`` [SI] and covariance ``cov``, plus
    independent ``vary`` distributions (they replace a jointly drawn parameter of the same
    name); ``source`` "covariance" | "std_errors" | "assumed" | "none" says where the joint
    part comes from, ``assumed`` the parameters whose standard deviation is assumed; ``specs``
    the parameter declarations whose bounds the draws must keep."""

    names: tuple[str, ...] = ()
    mean: np.ndarray = field(default_factory=lambda: np.zeros(0))
    cov: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    source: str = "none"
    vary: tuple[Distribution, ...] = ()
    assumed: tuple[str, ...] = ()
    specs: Mapping[str, Any] = field(default_factory=dict)

    # -- reading ---------------------------------------------------------------------------
    @classmethod
    def from_model(cls, model: Any, *, rel: float | None = None,
                   source: str = "model") -> Uncertainty:
        """The uncertainty a model stores (``model.identification``): its ``covariance``
        (``{"names", "matrix"}``) when present, else its ``std_errors`` (independent; a
        parameter with a standard error of 0, held at its prior, is not drawn). ``rel``: a
        relative standard deviation assumed for the other fitted parameters (``rel |p|``).
        ``source`` (a file name) prefixes the errors, which name the offending entry."""
        dyn = model.dynamics
        specs = {p.name: p for p in type(dyn).param_specs()}
        numeric = {n for n, p in specs.items() if p.submodel is None}
        ident = getattr(model, "identification", None) or {}
        if not isinstance(ident, Mapping):
            raise UsvidError(f"{source}: identification must be an object")

        def value(n: str) -> float:
            v = np.asarray(getattr(dyn, n), dtype=float)
            if v.ndim:
                raise UsvidError(f"{source}: parameter {n} is a batch; one model is sampled")
            return float(v)

        names: list[str] = []
        cov = np.zeros((0, 0))
        kind = "none"
        block = ident.get("covariance")
        if block:
            names, cov = _read_covariance(block, numeric, f"{source}: identification.covariance")
            kind = "covariance"
        else:
            se = ident.get("std_errors") or {}
            if not isinstance(se, Mapping):
                raise UsvidError(f"{source}: identification.std_errors must be an object "
                                 f"(got {type(se).__name__})")
            sds = []
            for n, v in se.items():
                if v is None or (isinstance(v, float) and not math.isfinite(v)):
                    continue  # not determined (null, NaN, inf in memory): not drawn
                where = f"{source}: identification.std_errors.{n}"
                if n not in numeric:
                    raise UsvidError(f"{where}: not a parameter of kind '{model.kind}' "
                                     f"(parameters: {', '.join(sorted(numeric))})")
                if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
                    raise UsvidError(f"{where} must be a finite number (got {v!r})")
                if v < 0:
                    raise UsvidError(f"{where} must be >= 0 (got {v!r}): a standard error is "
                                     "never negative")
                if v > 0:
                    names.append(n)
                    sds.append(float(v))
            if names:
                cov = np.diag(np.square(sds))
                kind = "std_errors"
        assumed: list[str] = []
        if rel is not None:
            if not (math.isfinite(rel) and rel >= 0):
                raise UsvidError(f"the assumed relative uncertainty must be >= 0 (got {rel!r})")
            extra = [n for n in type(dyn).fit_names() if n not in names
                     and not (block and n in _names_of(block))
                     and (ident.get("std_errors") or {}).get(n) is None
                     and np.ndim(getattr(dyn, n)) == 0 and value(n) != 0.0 and rel > 0]
            if extra:
                sd = [rel * abs(value(n)) for n in extra]
                k = len(names)
                big = np.zeros((k + len(extra), k + len(extra)))
                big[:k, :k] = cov
                big[k:, k:] = np.diag(np.square(sd))
                names, cov, assumed = [*names, *extra], big, extra
                kind = "assumed" if kind == "none" else kind
        mean = np.array([value(n) for n in names], dtype=float)
        return cls(tuple(names), mean, cov, kind, (), tuple(assumed), specs)

    def with_vary(self, vary: Sequence[Distribution]) -> Uncertainty:
        """The same with further independent distributions (``--vary``); a name that is not a
        parameter of the model is an error naming it."""
        for v in vary:
            if self.specs and v.name not in self.specs:
                raise UsvidError(f"--vary {v.name}: not a parameter of the model (parameters: "
                                 f"{', '.join(sorted(self.specs))})")
        return Uncertainty(self.names, self.mean, self.cov, self.source, tuple(vary),
                           self.assumed, self.specs)

    @property
    def parameters(self) -> tuple[str, ...]:
        """The sampled parameter names, in column order."""
        return (*self.names, *(v.name for v in self.vary if v.name not in self.names))

    def std(self) -> dict[str, float]:
        """Standard deviation [SI] of each jointly normal parameter."""
        return {n: float(math.sqrt(max(self.cov[i, i], 0.0)))
                for i, n in enumerate(self.names)}

    def to_dict(self) -> dict[str, Any]:
        """Where the draws come from: ``source``, per parameter ``value``, ``std`` and
        ``source`` (the stored uncertainty or "assumed"), and the ``vary`` distributions."""
        sd = self.std()
        return {"source": self.source,
                "parameters": {n: {"value": float(self.mean[i]), "std": sd[n],
                                   "source": "assumed" if n in self.assumed else self.source}
                               for i, n in enumerate(self.names)},
                "vary": [f"{v.name}={v.dist}:{v.a:g},{v.b:g}" for v in self.vary]}

    # -- sampling --------------------------------------------------------------------------
    def _factor(self) -> np.ndarray:
        k = len(self.names)
        if k == 0:
            return np.zeros((0, 0))
        try:
            return np.linalg.cholesky(self.cov)
        except np.linalg.LinAlgError:  # semi-definite: through the eigen-decomposition
            w, v = np.linalg.eigh(self.cov)
            return v * np.sqrt(np.clip(w, 0.0, None))

    def _out_of_bounds(self, draws: Mapping[str, np.ndarray], rows: np.ndarray) -> np.ndarray:
        bad = np.zeros(rows.size, dtype=bool)
        for n, x in draws.items():
            bad |= _bounds_mask(self.specs.get(n), x[rows])
        return bad

    def _block(self, seed: int, blk: int, L: np.ndarray
               ) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
        rng = np.random.default_rng([int(seed), int(blk)])

        def joint(n_rows: int) -> np.ndarray:
            return self.mean + rng.standard_normal((n_rows, len(self.names))) @ L.T

        draws: dict[str, np.ndarray] = {}
        if self.names:
            x = joint(BLOCK)
            draws.update({n: x[:, i].copy() for i, n in enumerate(self.names)})
        for v in self.vary:
            draws[v.name] = v.draw(rng, BLOCK)

        def again(bad: np.ndarray) -> None:
            if self.names:
                x = joint(bad.size)
                for i, n in enumerate(self.names):
                    draws[n][bad] = x[:, i]
            for v in self.vary:
                draws[v.name][bad] = v.draw(rng, bad.size)

        redraws, failed = redraw_invalid(BLOCK, lambda rows: self._out_of_bounds(draws, rows),
                                         again)
        return draws, redraws, failed

    def sample(self, lo: int, hi: int, seed: int = 0) -> Sample:
        """The parameters [SI] of runs ``lo .. hi-1`` (module docstring: block-seeded, the
        bounds policy)."""
        if not 0 <= lo < hi:
            raise UsvidError(f"runs {lo}..{hi - 1}: an empty or negative range of runs")
        if not 0 <= int(seed) < 2**63:
            raise UsvidError(f"seed must be in 0 .. 2^63 - 1 (got {seed})")
        L = self._factor()
        names = self.parameters
        parts: dict[str, list[np.ndarray]] = {n: [] for n in names}
        red, fail = [], []
        for blk in range(lo // BLOCK, (hi - 1) // BLOCK + 1):
            draws, redraws, failed = self._block(seed, blk, L)
            a = max(lo, blk * BLOCK) - blk * BLOCK
            b = min(hi, (blk + 1) * BLOCK) - blk * BLOCK
            for n in names:
                parts[n].append(draws[n][a:b])
            red.append(redraws[a:b])
            fail.append(failed[a:b])
        mean = {n: float(self.mean[i]) for i, n in enumerate(self.names)}
        for v in self.vary:  # a nominal value inside the distribution
            if v.name not in mean:
                mean[v.name] = v.a if v.dist == "normal" else 0.5 * (v.a + v.b)
        return Sample({n: np.concatenate(p) for n, p in parts.items()},
                      np.concatenate(red), np.concatenate(fail), mean)


def _names_of(block: Any) -> list[str]:
    names = block.get("names") if isinstance(block, Mapping) else None
    return list(names) if isinstance(names, list) else []


def _read_covariance(block: Any, known: set[str], where: str) -> tuple[list[str], np.ndarray]:
    """``(names, matrix)`` of a stored covariance block, checked: an object with ``names``
    (distinct parameters of the model) and ``matrix`` (square, as many rows and columns as
    names, finite, symmetric, positive semi-definite)."""
    if not isinstance(block, Mapping):
        raise UsvidError(f"{where} must be an object {{names, matrix}} "
                         f"(got {type(block).__name__})")
    names, matrix = block.get("names"), block.get("matrix")
    if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
        raise UsvidError(f"{where}.names must be a list of parameter names (got {names!r:.60})")
    for i, n in enumerate(names):
        if n not in known:
            raise UsvidError(f"{where}.names[{i}] = {n!r} is not a parameter of the model "
                             f"(parameters: {', '.join(sorted(known))})")
    if len(set(names)) != len(names):
        dup = next(n for n in names if names.count(n) > 1)
        raise UsvidError(f"{where}.names lists {dup!r} twice")
    k = len(names)
    if not isinstance(matrix, list) or len(matrix) != k:
        got = f"{len(matrix)} rows" if isinstance(matrix, list) else type(matrix).__name__
        raise UsvidError(f"{where}.matrix must be a list of {k} rows, one per name (got {got})")
    for i, row in enumerate(matrix):
        if not isinstance(row, list) or len(row) != k:
            got = (f"{len(row)} number{'' if len(row) == 1 else 's'}" if isinstance(row, list)
                   else type(row).__name__)
            raise UsvidError(f"{where}.matrix[{i}] must be a row of {k} numbers (got {got})")
        for j, v in enumerate(row):
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
                raise UsvidError(f"{where}.matrix[{i}][{j}] must be a finite number "
                                 f"(got {v!r})")
    C = np.array(matrix, dtype=float).reshape(k, k)
    scale = max(float(np.max(np.abs(C))), 1e-300) if k else 1.0
    asym = np.abs(C - C.T)
    if k and asym.max() > 1e-8 * scale:
        i, j = np.unravel_index(int(np.argmax(asym)), asym.shape)
        raise UsvidError(f"{where}.matrix is not symmetric: [{i}][{j}] = {C[i, j]:g} but "
                         f"[{j}][{i}] = {C[j, i]:g}")
    d = np.diag(C)
    if k and np.any(d < 0):
        i = int(np.argmin(d))
        raise UsvidError(f"{where}.matrix[{i}][{i}] (the variance of {names[i]}) must be >= 0 "
                         f"(got {d[i]:g})")
    if k:
        w = np.linalg.eigvalsh(0.5 * (C + C.T))
        if w.min() < -1e-9 * max(w.max(), 1e-300):
            raise UsvidError(f"{where}.matrix is not positive semi-definite (smallest "
                             f"eigenvalue {w.min():g}): not a covariance")
    return list(names), 0.5 * (C + C.T)


def lane_errors(dynamics: Any, values: Mapping[str, np.ndarray]) -> dict[int, str]:
    """The lanes of a batch of parameter sets (``values`` name -> (n,)) that are no valid
    parameter set of ``dynamics``' kind (a check across parameters the bounds do not cover),
    each with its error message: run index -> message. Empty when the whole batch is valid
    (checked at once; lane by lane only when it is not)."""
    try:
        dynamics.replace(**values)
        return {}
    except (UsvidError, ValueError, TypeError):
        pass
    n = len(next(iter(values.values())))
    out = {}
    for i in range(n):
        try:
            dynamics.replace(**{k: float(v[i]) for k, v in values.items()})
        except (UsvidError, ValueError, TypeError) as exc:
            out[i] = str(exc)
    return out
