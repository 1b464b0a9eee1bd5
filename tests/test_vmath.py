"""The branch-free asin and exp (usvid.models.vmath) against the C library's (Python's math)."""

from __future__ import annotations

import math

import numba
import numpy as np

from usvid.models import vmath


@numba.njit(cache=True)
def _both(x):
    a = np.empty_like(x)
    e = np.empty_like(x)
    for i in range(x.size):
        a[i] = vmath.asin(x[i])
        e[i] = vmath.exp(x[i] * 700.0)
    return a, e


def _ulps(got: np.ndarray, want: np.ndarray) -> np.ndarray:
    return np.abs(got - want) / np.spacing(np.abs(want))


def test_asin_and_exp_within_two_ulps_of_the_library():
    rng = np.random.default_rng(5)
    # every case of the argument reduction: |x| < 0.5, 0.5 <= |x| < 0.975, above, both signs,
    # tiny values, the ends; exp from -700 to 700 (ulps of the correctly rounded library value)
    x = np.concatenate([rng.uniform(-1.0, 1.0, 20000), [-1.0, 1.0, 0.5, -0.5, 0.975, 1e-300,
                                                        -1e-12, 0.0, 0.49999999999999994]])
    a, e = _both(x)
    want_a = np.array([math.asin(v) for v in x])
    want_e = np.array([math.exp(v * 700.0) for v in x])
    assert _ulps(a, want_a).max() <= 2.0  # fdlibm's bound for this form (module docstring)
    assert _ulps(e, want_e).max() <= 1.0
    assert a[x == 0.0][0] == 0.0 and e[x == 0.0][0] == 1.0


def test_outside_the_domain():
    a, e = _both(np.array([1.5, -2.0, math.nan]))
    assert np.isnan(a).all()
    # asin NaN outside [-1, 1]; exp clamped to its finite range, NaN kept
    assert np.isnan(e[2]) and e[0] == vmath.exp(709.0) == math.exp(709.0)
