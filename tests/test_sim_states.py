"""A kind may have any number of states: the core generates its joint-state rows from the names.

A kind declared here (not registered) with seven states, a cascade of first-order lags ending in
the yaw rate, ``T x_k' = x_{k+1} - x_k``, ``T x_7' = K delta - x_7``, ``r = x_1``: the yaw rate's
transfer function is ``K / (1 + T s)^7``. Integrated by the core's vector and per-lane paths
under a constant measured rudder angle, it matches the exact solution of the linear system
(matrix exponential), and both paths agree.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numba
import numpy as np
import pytest
from scipy.linalg import expm

from usvid.models.kind import Dynamics, ModelKind, param, rows
from usvid.models.servo import IdealServo
from usvid.sim import core
from usvid.sim.simulate import Lanes, initial_state, servo_rows

NS = 7
STATES = ("r",) + tuple(f"x{k}" for k in range(2, NS + 1))


@dataclass
class Chain(Dynamics):
    """A cascade of NS lags: K [1/s], T [s]."""

    K: Any = param("1/s", "gain")
    T: Any = param("s", "time constant of each lag", gt=0.0)
    kind: ClassVar[str] = "chain"


@numba.njit(cache=False, forceinline=True)
def _rhs(p, s, a, f):  # noqa: ARG001 - the kind contract
    it = p[2]
    return (p[3], 0.0, s[0],
            ((s[1] - s[0]) * it, (s[2] - s[1]) * it, (s[3] - s[2]) * it, (s[4] - s[3]) * it,
             (s[5] - s[4]) * it, (s[6] - s[5]) * it, (p[0] * a[0] - s[6]) * it))


def _pack(d: Chain, speed: Any) -> np.ndarray:
    return rows([d.K, d.T, 1.0 / np.asarray(d.T, float), speed])


CHAIN = ModelKind(name="chain", title="lag cascade", equation="r/delta = K/(1 + T s)^7",
                  reference="test", dynamics=Chain, states=STATES, body=(-1, -1, 0), speed_row=3,
                  inputs=("delta",), rhs=_rhs, pack=_pack, outputs=("psi", "r"))


def _exact(K: float, T: float, delta: float, t: np.ndarray) -> np.ndarray:
    """(len(t), NS) states of the cascade from rest under a constant delta [rad]."""
    A = np.zeros((NS, NS))
    for k in range(NS):
        A[k, k] = -1.0 / T
        if k + 1 < NS:
            A[k, k + 1] = 1.0 / T
    b = np.zeros(NS)
    b[-1] = K * delta / T
    xs = -np.linalg.solve(A, b)  # steady state
    return np.array([xs - expm(A * ti) @ xs for ti in t])


@pytest.mark.parametrize("simd", [True, False], ids=["vector", "per_lane"])
def test_a_seven_state_kind_matches_the_exact_solution(simd):
    B, dt, n = core.CH + 3, 0.02, 1500
    K = np.linspace(0.1, 0.4, B)
    dyn = Chain(K=K, T=2.0)
    P = np.broadcast_to(CHAIN.pack(dyn, 1.5), (4, B))
    skind, S = servo_rows(IdealServo(), B)
    delta = math.radians(10.0)
    Z0 = initial_state(CHAIN, dyn, B, values={"delta": delta})
    lanes = Lanes(kind=CHAIN, P=P, servo=skind, S=S, Z0=Z0, nsteps=np.full(B, n), dt=dt,
                  series={"delta": np.full((1, n + 1), delta)}, channels=("psi", "r", "U"))
    try:
        core.SIMD = simd
        out = lanes.run()
    finally:
        core.SIMD = True
    t = out.t
    for b in (0, B - 1):
        want = _exact(K[b], 2.0, delta, t)
        # RK4 at dt = T/100: local error ~ (dt/T)^5 per step, global ~1e-10 of the scale
        np.testing.assert_allclose(out.channels["r"][b], want[:, 0], rtol=0.0,
                                   atol=1e-9 * K[b] * delta)
        psi = np.concatenate([[0.0], np.cumsum(0.5 * dt * (want[1:, 0] + want[:-1, 0]))])
        np.testing.assert_allclose(out.channels["psi"][b], psi, rtol=0.0, atol=1e-5 * K[b])
    assert np.all(out.channels["U"] == 1.5)
    assert np.all(out.status[0] == 0)


@dataclass
class Roller(Dynamics):
    """A yaw lag and a linear roll oscillator: omega [rad/s], zeta [-]."""

    omega: Any = param("rad/s", "roll natural frequency", gt=0.0)
    zeta: Any = param("-", "roll damping ratio", ge=0.0)
    kind: ClassVar[str] = "roller"


@numba.njit(cache=False, forceinline=True)
def _roll_rhs(p, s, a, f):  # noqa: ARG001 - the kind contract
    w = p[0]
    return 1.0, 0.0, s[0], (-s[0], -w * w * s[2] - 2.0 * p[1] * w * s[1], s[1])


ROLLER = ModelKind(name="roller", title="roll oscillator", equation="phi'' + 2 z w phi' + w^2 phi",
                   reference="test", dynamics=Roller, states=("r", "p", "phi"),
                   body=(-1, -1, 0), speed_row=2, inputs=("delta",), rhs=_roll_rhs,
                   pack=lambda d, speed: rows([d.omega, d.zeta, speed]), outputs=("psi", "r"))


def test_roll_states_are_recorded_as_channels_phi_and_p():
    """A kind with states named phi and p: the core records them as channels phi, p (the
    roll angle of a damped oscillator from phi0 = 0.1 rad, exact solution), with any number and
    order of states."""
    B, dt, n = 3, 0.01, 1000
    dyn = Roller(omega=np.array([1.0, 2.0, 3.0]), zeta=0.1)
    skind, S = servo_rows(IdealServo(), B)
    Z0 = initial_state(ROLLER, dyn, B, values={"phi": 0.1})
    lanes = Lanes(kind=ROLLER, P=ROLLER.pack(dyn, 1.0), servo=skind, S=S, Z0=Z0,
                  nsteps=np.full(B, n), dt=dt, channels=("phi", "p"))
    out = lanes.run()
    for b, w in enumerate((1.0, 2.0, 3.0)):
        z = 0.1
        wd = w * math.sqrt(1 - z * z)
        t = out.t
        want = 0.1 * np.exp(-z * w * t) * (np.cos(wd * t) + z * w / wd * np.sin(wd * t))
        # RK4 at w dt <= 0.03 over w t <= 30 rad: global error <= A (w dt)^4 w t / 120 = 2e-8
        np.testing.assert_allclose(out.channels["phi"][b], want, rtol=0.0, atol=2e-8)
        rate = -0.1 * w * w / wd * np.exp(-z * w * t) * np.sin(wd * t)
        np.testing.assert_allclose(out.channels["p"][b], rate, rtol=0.0, atol=2e-8 * w)


@pytest.mark.parametrize("n", [0, 3, 8])
def test_a_kind_interleaves_one_two_or_four_lane_vectors(n):
    # the vector step's interleave is LLVM's vectoriser option: 1, 2 or 4 vectors side by side
    # (the MMG kind's 2 is checked against the per-lane path in test_sim_mmg_vector.py)
    with pytest.raises(ValueError, match="vector_interleave 1, 2 or 4"):
        dataclasses.replace(CHAIN, name="chain_il", vector_interleave=n)
