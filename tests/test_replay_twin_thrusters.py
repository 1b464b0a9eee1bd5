"""The replay of a twin-thruster kind (usvid.sim.replay): the windows of a catamaran driven by
its logged thruster commands reproduce its simulation, whatever rudder-equivalent angle the log
also carries; and why a directionally unstable catamaran replays badly from noisy states (the
physics, not the replay)."""

from __future__ import annotations

import numpy as np
import pytest

from usvid.identify.metrics import replay_metrics
from usvid.models import Catamaran
from usvid.models.model import VesselModel
from usvid.sim import Commanded
from usvid.sim.replay import make_windows, replay_windows
from usvid.sim.simulate import simulate
from usvid.trial import Vessel

#: The catamaran of tests/test_identify_current_regression.py: m11 < m22 (a destabilising Munk
#: moment (m11 - m22) u v) and a yaw damping that does not grow with the speed.
CAT = Catamaran(m11=80.0, m22=120.0, m33=30.0, d11=25.0, d22=70.0, d33=40.0, b=0.8,
                thrust=0.5)


@pytest.fixture(scope="module")
def record():
    """120 s of commands held 15 s (levels 20-100, differentials +-40, every third straight),
    from rest, simulated at 0.02 s; the states and commands every 0.1 s as a replay's series
    (the smoothed states the exact ones)."""
    t = np.arange(0.0, 120.01, 0.1)
    rng = np.random.default_rng(0)
    seg = (t // 15).astype(int)
    lev = rng.uniform(20, 100, seg.max() + 1)[seg]
    dif = rng.uniform(-40, 40, seg.max() + 1)
    dif[::3] = 0.0
    dif = dif[seg]
    model = VesselModel(CAT, vessel=Vessel(length=1.5))
    res = simulate(model, Commanded(t=t, n_port=lev + dif, n_stbd=lev - dif), t_end=120.0,
                   dt=0.02, u0=0.0)
    s = {k: np.asarray(res.channels[k][0])[::5] for k in ("psi", "r", "u", "v", "n_port",
                                                          "n_stbd")}
    s["psi"] = np.unwrap(s["psi"])
    for k in ("psi", "r", "u", "v"):
        s[f"{k}_s"] = s[k]
    return model, s


def _rmse(model, s, window_s=20.0):
    win = make_windows([s], 0.1, window_s)
    return replay_metrics(replay_windows(model, win), win.outputs)


def test_replay_follows_the_thruster_commands(record):
    """From the simulated states, the 20-s windows reproduce the simulated heading: the core's
    RK4 at 0.1 s against 0.02 s and the commands' first-order hold (measured: below 1e-5 rad;
    tolerance 1e-3 rad). A logged rudder-equivalent angle of 0.3 rad beside the thruster
    commands changes nothing (the commands, not the angle, drive the thrusters)."""
    model, s = record
    base = _rmse(model, s)
    assert base["psi"]["rmse"] < 1e-3 and base["u"]["rmse"] < 1e-3
    with_delta = _rmse(model, {**s, "delta": np.full_like(s["psi"], 0.3)})
    for ch in ("psi", "r", "u", "v"):
        assert with_delta[ch]["rmse"] == pytest.approx(base[ch]["rmse"], rel=1e-9, abs=1e-12)


def test_an_unstable_catamaran_amplifies_a_small_start_error(record):
    """The kind's sway and yaw equations linearised on a straight run at speed u
    (v' = (-d22 v - m11 u r) / m22, r' = ((m11 - m22) u v - d33 r) / m33) have the determinant
    (d22 d33 - m11 (m11 - m22) u^2) / (m22 m33): negative (an unstable root) above
    u = sqrt(d22 d33 / (m11 (m22 - m11))) = 0.935 m/s for this catamaran; at 2 m/s the root is
    +0.964 1/s (by hand: trace -1.917, determinant -2.778). The record's speed reaches 2 m/s,
    so a 1 mm/s error in each window's initial sway velocity turns into a heading error of
    order 1 rad over 20 s (measured 1.6 rad; over 0.3 asked): the 0.93 rad the noisy logs of
    this catamaran replay with in the current regression is this, not the replay."""
    model, s = record
    u = 2.0
    A = np.array([[-CAT.d22 / CAT.m22, -CAT.m11 * u / CAT.m22],
                  [(CAT.m11 - CAT.m22) * u / CAT.m33, -CAT.d33 / CAT.m33]])
    assert max(np.linalg.eigvals(A).real) == pytest.approx(0.964212, abs=1e-5)
    assert np.sqrt(CAT.d22 * CAT.d33 / (CAT.m11 * (CAT.m22 - CAT.m11))) == pytest.approx(
        0.935414, abs=1e-6)
    assert np.max(s["u"]) > 1.5
    off = _rmse(model, {**s, "v_s": s["v"] + 1e-3})
    assert off["psi"]["rmse"] > 0.3
