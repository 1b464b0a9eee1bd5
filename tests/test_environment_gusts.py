"""Gusts and wind series (usvid.models.environment.gusts): the Harris and NORSOK spectra against
hand values, seeded gust series with the spectrum's variance, wind on a time grid."""

from __future__ import annotations

import math

import numpy as np
import pytest

from usvid.errors import UsvidError
from usvid.models.environment._spectral import sum_cos
from usvid.models.environment.gusts import (
    gust_series,
    gust_spectrum,
    harris_spectrum,
    norsok_spectrum,
    wind_on_grid,
)


def test_harris_by_hand():
    # S(0) = 4 kappa L U / 2^(5/6) = 4 * 0.0026 * 1800 * 10 / 1.781797 = 105.0624 (m/s)^2/Hz
    assert harris_spectrum(0.0, 10.0) == pytest.approx(187.2 / 2 ** (5 / 6), rel=1e-12)
    assert harris_spectrum(0.0, 10.0) == pytest.approx(105.0624, rel=1e-6)
    # f L / U = 1 at f = U / L: 4 kappa L U / 3^(5/6)
    assert harris_spectrum(10.0 / 1800.0, 10.0) == pytest.approx(187.2 / 3 ** (5 / 6))
    # variance 4 kappa U^2 int (2 + x^2)^(-5/6) dx = 4 kappa U^2 2^(-1/3) sqrt(pi)
    # Gamma(1/3) / (2 Gamma(5/6)) = 0.017361 U^2 (the slow f^(-5/3) tail: quadrature to 1e5 Hz
    # leaves 0.3 % out)
    var = 4 * 0.0026 * 2 ** (-1 / 3) * math.sqrt(math.pi) * math.gamma(1 / 3) / (
        2 * math.gamma(5 / 6))
    f = np.geomspace(1e-7, 1e5, 400_001)
    assert np.trapezoid(harris_spectrum(f, 1.0), f) == pytest.approx(var, rel=0.005)
    assert var == pytest.approx(0.017361, rel=1e-4)


def test_norsok_by_hand():
    # U = 10 m/s, z = 10 m: S = 320 / (1 + (172 f)^0.468)^(5 / 1.404); at f = 0.01 Hz,
    # 1.72^0.468 = 1.288924, 2.288924^3.561254 = 19.08704, S = 16.76531 (m/s)^2/Hz
    assert norsok_spectrum(0.0, 10.0) == pytest.approx(320.0)
    assert norsok_spectrum(0.01, 10.0) == pytest.approx(16.76531, rel=1e-6)
    # height and speed scaling: (U/10)^2 (z/10)^0.45 at f = 0
    assert norsok_spectrum(0.0, 5.0, z=20.0) == pytest.approx(320 * 0.25 * 2**0.45)
    with pytest.raises(UsvidError, match="spectrum must be"):
        gust_spectrum("davenport", 5.0)


@pytest.mark.parametrize("name", ["norsok", "harris"])
def test_gust_series_mean_variance_and_seed(name):
    """200 lanes x 1 h at 1 Hz: mean within 2 % of the mean wind and variance within 10 % of
    the spectrum's over the realised band (the 1/3600 Hz components hardly average out in an
    hour: the variance scatters by some 10 % between lanes, 1 / sqrt(200) of that in the mean)."""
    U = 4.0
    t = np.arange(0.0, 3600.0, 1.0)
    u = gust_series(t, U, spectrum=name, seed=3, n_batch=200)
    assert u.shape == (200, t.size) and np.all(u >= 0)
    f = np.geomspace(1 / 3600, 0.5, 100_001)
    var = np.trapezoid(gust_spectrum(name, U)(f), f)
    assert u.mean() == pytest.approx(U, rel=0.02)
    assert u.var(axis=1).mean() == pytest.approx(var, rel=0.10)
    again = gust_series(t, U, spectrum=name, seed=3, n_batch=2)
    np.testing.assert_array_equal(again, u[:2])
    assert not np.array_equal(gust_series(t, U, spectrum=name, seed=4, n_batch=2), again)


def test_calm_and_bad_inputs():
    t = np.arange(0.0, 10.0, 0.1)
    assert np.all(gust_series(t, 0.0, n_batch=2) == 0.0)
    with pytest.raises(UsvidError, match="mean_speed"):
        gust_series(t, -1.0)
    with pytest.raises(UsvidError, match="increasing"):
        gust_series(t[::-1], 3.0)
    with pytest.raises(UsvidError, match="seed"):
        gust_series(t, 3.0, seed=-2)


def test_wind_on_grid_constants_series_and_logs():
    t = np.arange(0.0, 10.5, 0.5)
    s, d = wind_on_grid(t, 3.0, 2 * math.pi + 0.1)
    assert s.shape == d.shape == t.shape and np.all(s == 3.0)
    np.testing.assert_allclose(d, 0.1)
    # a logged series from 350 deg to 10 deg passes through north, not south
    s, d = wind_on_grid(t, [2.0, 4.0], np.radians([350.0, 10.0]), t_source=[0.0, 10.0])
    assert s[10] == pytest.approx(3.0)
    assert math.degrees(d[10]) == pytest.approx(0.0, abs=1e-9) or \
        math.degrees(d[10]) == pytest.approx(360.0, abs=1e-9)
    # a (batch, time) series from gust_series is accepted as it is
    g = gust_series(t, 5.0, n_batch=3)
    s, d = wind_on_grid(t, g, 1.0)
    assert s.shape == (3, t.size) and d.shape == (3, t.size)
    with pytest.raises(UsvidError, match="do not match"):
        wind_on_grid(t, np.ones(4), 0.0)
    with pytest.raises(UsvidError, match=">= 0"):
        wind_on_grid(t, -1.0, 0.0)


def test_phasor_sum_equals_the_cosines():
    rng = np.random.default_rng(2)
    w, a, ph = rng.uniform(0.1, 3, (2, 7)), rng.uniform(0, 1, (2, 7)), rng.uniform(0, 6, (2, 7))
    t = np.arange(0.0, 500.0, 0.3)
    ref = np.einsum("bk,bkt->bt", a, np.cos(w[..., None] * t + ph[..., None]))
    out = np.zeros((2, t.size))
    sum_cos(w, a, ph, t, out)  # uniform grid: rotated phasors
    np.testing.assert_allclose(out, ref, atol=1e-11)
    t2 = np.sort(rng.uniform(0, 500, 300))
    out = np.zeros((2, t2.size))
    sum_cos(w, a, ph, t2, out)  # uneven grid: cosines
    ref = np.einsum("bk,bkt->bt", a, np.cos(w[..., None] * t2 + ph[..., None]))
    np.testing.assert_allclose(out, ref, atol=1e-12)
