"""Discrete-to-continuous conversion: hand values, round trips through scipy, delays, errors."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import signal

from usvid.errors import IdentificationError
from usvid.models.d2c import d2c, d2c_ss, split_delay

WN, ZETA = np.sqrt(1.95), 2.38125 / (2 * np.sqrt(1.95))  # Mu et al. 2018 servo

SYSTEMS = {
    "first_order": ([0.707], [0.332, 1.0]),  # Mu et al. 2018 Nomoto K / (T s + 1)
    "second_order_underdamped": ([1.95], [1.0, 2.38125, 1.95]),
    "third_order_with_zero": ([2.0, 1.0], [1.0, 3.0, 4.0, 2.0]),
    # psi/delta, Mu et al. 2016 eq. 25 form
    "heading_with_integrator": ([0.707], [0.332, 1.0, 0.0]),
}


def test_first_order_by_hand():
    # ZOH of K / (T s + 1): a = exp(-dt/T), b = K (1 - a); inverse T = -dt / ln a, K = b / (1 - a)
    dt, a, b = 0.1, 0.8, 0.3
    c = d2c([b], [1.0, -a], dt)
    T = -dt / np.log(a)
    np.testing.assert_allclose(c.den, [1.0, 1 / T], rtol=1e-10)
    np.testing.assert_allclose(c.num, [b / (1 - a) / T], rtol=1e-10)
    assert c.dc_gain == pytest.approx(b / (1 - a), rel=1e-10)
    assert c.delay_samples == 0


@pytest.mark.parametrize("name", list(SYSTEMS))
@pytest.mark.parametrize("method, sp_method", [("zoh", "zoh"), ("tustin", "bilinear")])
@pytest.mark.parametrize("delay", [0, 3])
def test_round_trip_through_scipy(name, method, sp_method, delay):
    num, den = SYSTEMS[name]
    dt = 0.05
    nd, dd, _ = signal.cont2discrete((num, den), dt, method=sp_method)
    nd = np.ravel(nd)
    dd = np.concatenate([dd, np.zeros(delay)])  # z^-delay: poles at z = 0
    c = d2c(nd, dd, dt, method)
    assert c.delay_samples == delay
    assert c.delay_s == pytest.approx(delay * dt)
    # normalised coefficients agree to round-off of logm/expm (1e-7 relative is generous)
    num_n = np.asarray(num, float) / den[0]
    den_n = np.asarray(den, float) / den[0]
    np.testing.assert_allclose(c.den, den_n, rtol=1e-7)
    np.testing.assert_allclose(c.num[-num_n.size:], num_n, rtol=1e-7, atol=1e-9)
    assert np.allclose(c.num[:-num_n.size], 0.0, atol=1e-8)


def test_servo_arx_form_with_delay():
    # ARX form (b1 z^-1 + b2 z^-2) z^-50 / (1 + a1 z^-1 + a2 z^-2) -> 1 s dead time at dt = 0.02
    dt = 0.02
    nd, dd, _ = signal.cont2discrete(([1.95], [1, 2.38125, 1.95]), dt, method="zoh")
    b = np.concatenate([np.zeros(50), np.ravel(nd)])  # leading zeros = delay (+ the ZOH sample)
    c = d2c(b, dd, dt, variable="z^-1")
    assert c.delay_samples == 50 and c.delay_s == pytest.approx(1.0)
    wn = np.sqrt(c.den[2])
    assert wn == pytest.approx(WN, rel=1e-8)
    assert c.den[1] / (2 * wn) == pytest.approx(ZETA, rel=1e-8)
    tf = c.to_control()
    assert float(np.real(tf.dcgain())) == pytest.approx(1.0, rel=1e-8)


def test_state_space_round_trip_two_inputs():
    A = np.array([[0.0, 1.0], [-2.0, -0.5]])
    B = np.array([[0.0, 1.0], [1.0, 0.3]])
    C = np.array([[1.0, 0.0]])
    D = np.array([[0.0, 0.1]])
    for m, spm in (("zoh", "zoh"), ("tustin", "bilinear")):
        Ad, Bd, Cd, Dd, _ = signal.cont2discrete((A, B, C, D), 0.1, method=spm)
        Ac, Bc, Cc, Dc = d2c_ss(Ad, Bd, Cd, Dd, 0.1, m)
        for got, want in ((Ac, A), (Bc, B), (Cc, C), (Dc, D)):
            np.testing.assert_allclose(got, want, atol=1e-9)


def test_negative_real_pole_is_an_error():
    # Mu et al. 2016 eq. 23 has a discrete pole at z = -0.4133: no real ZOH continuous equivalent
    with pytest.raises(IdentificationError, match="-0.4133.*no real continuous ZOH"):
        d2c([0.2743, 0.2122, -0.118], [1, -0.9537, -0.5476, 0.007182], 0.5)
    # Tustin does map it (to a fast real pole)
    c = d2c([0.2743, 0.2122, -0.118], [1, -0.9537, -0.5476, 0.007182], 0.5, "tustin")
    assert np.all(np.isfinite(c.den))


def test_mu2016_eq26_is_not_the_zoh_of_eq27():
    # eq. 26 poles: z = -0.7765 +- 0.5604 j (|z| = 0.9576, angle 2.517 rad). Under ZOH
    # zeta = -ln|z| / sqrt(ln|z|^2 + angle^2) = 0.0172 for ANY dt, not the printed 0.811:
    # the printed pair is not self-consistent (as the seed README warns).
    for dt in (0.02, 0.1, 0.5, 2.0):
        c = d2c([-0.2724, 0.8464], [1, 1.553, 0.9169], dt)
        zeta = c.den[1] / (2 * np.sqrt(c.den[2]))
        assert zeta == pytest.approx(0.0172, abs=2e-4)


def test_split_delay_rules_and_errors():
    # relative degree 3 under ZOH -> 2 samples of delay; under Tustin -> 3
    assert split_delay([1.0], [1, -0.5, 0, 0], "zoh")[2] == 2
    assert split_delay([1.0], [1, -0.5, 0, 0], "tustin")[2] == 3
    with pytest.raises(IdentificationError, match="not a pure dead time"):
        d2c([1.0, 0.5, 0.2], [1.0, 0.0, 0.0], 0.1)
    with pytest.raises(IdentificationError, match="improper"):
        d2c([1.0, 0.5, 0.2], [1.0, 0.5], 0.1)
    with pytest.raises(IdentificationError, match="`method`"):
        d2c([1.0], [1.0, -0.5], 0.1, "foh")
    with pytest.raises(IdentificationError, match="`dt`"):
        d2c([1.0], [1.0, -0.5], 0.0)
    with pytest.raises(IdentificationError, match="numerator is zero"):
        d2c([0.0], [1.0, -0.5], 0.1)


@settings(max_examples=15, deadline=None)
@given(wn=st.floats(0.2, 5.0), zeta=st.floats(0.05, 2.0), dt=st.floats(0.01, 0.2),
       delay=st.integers(0, 5), gain=st.floats(0.1, 3.0))
def test_round_trip_property(wn, zeta, dt, delay, gain):
    # omega_d dt <= 5 * 0.2 = 1 < pi: the discrete poles stay off the negative real axis
    num, den = [gain * wn**2], [1.0, 2 * zeta * wn, wn**2]
    nd, dd, _ = signal.cont2discrete((num, den), dt, method="zoh")
    c = d2c(np.ravel(nd), np.concatenate([dd, np.zeros(delay)]), dt)
    assert c.delay_samples == delay
    # logm/expm round-off grows with the spread of time scales; 1e-6 relative is ample
    np.testing.assert_allclose(c.den, den, rtol=1e-6)
    assert c.dc_gain == pytest.approx(gain, rel=1e-6)
