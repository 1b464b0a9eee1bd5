"""Benchmark: recursive least squares over 180k samples (target <= 0.5 s; printed, not asserted).

180k samples = one hour of a 50 Hz log (Mu et al. 2018 samples every 0.02 s). Regressors: a
4-parameter ARX servo model and the 8-parameter Mu et al. 2018 eq. 37 3-DOF regression size.
Run: .venv/bin/python benchmarks/bench_identify_rls.py
"""

from __future__ import annotations

import time

import numpy as np

from usvid.identify.ls import LeastSquares
from usvid.identify.rls import RecursiveLeastSquares

N = 180_000


def _bench(p: int, lam: float) -> None:
    rng = np.random.default_rng(0)
    X = rng.normal(size=(N, p))
    theta = rng.normal(size=p)
    y = X @ theta + 0.01 * rng.normal(size=N)
    est = RecursiveLeastSquares(lam=lam)
    est.fit(X[:50], y[:50])  # numba compile / cache load outside the timing
    best = np.inf
    for _ in range(5):
        t0 = time.perf_counter()
        est.fit(X, y)
        best = min(best, time.perf_counter() - t0)
    t0 = time.perf_counter()
    LeastSquares().fit(X, y)
    t_ls = time.perf_counter() - t0
    err = float(np.max(np.abs(est.coef_ - theta)))
    print(f"RLS  N={N} p={p} lam={lam}: {best:.3f} s (best of 5; target <= 0.5 s), "
          f"max |theta error| = {err:.2e}; batch LS: {t_ls:.3f} s")


if __name__ == "__main__":
    _bench(4, 1.0)
    _bench(8, 0.999)
