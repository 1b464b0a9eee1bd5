"""Output error's batched Jacobian: the perturbed parameter sets of a finite-difference Jacobian
simulated as the lanes of one core call give the same outputs, hence the same Jacobian, as one
simulation per set (the algorithm it replaces); the process keeps one thread pool for the
core's chunks."""

from __future__ import annotations

import math

import numpy as np

from usvid.identify.output_error import OEProblem, fd_jacobian
from usvid.models import get_kind
from usvid.sim import core
from usvid.sim.replay import Windows

NOMOTO1 = get_kind("nomoto1")


def _windows(B: int = 40, W: int = 121, h: float = 0.1) -> Windows:
    """B windows of a zig-zag-like measured rudder (seeded), outputs from a Nomoto model with
    noise: enough windows (40) for two chunks of lanes per set."""
    rng = np.random.default_rng(7)
    t = np.arange(W) * h
    phase = rng.uniform(0, 2 * np.pi, (B, 1))
    delta = math.radians(10) * np.sign(np.sin(0.3 * t[None, :] + phase))
    r = np.cumsum(0.02 * delta, axis=1) * h + rng.normal(0, 1e-3, (B, W))
    psi = np.cumsum(r, axis=1) * h + rng.normal(0, 1e-3, (B, W))
    return Windows(h=h, inputs={"delta": delta}, outputs={"psi": psi, "r": r},
                   init={"r": r[:, 0], "psi": psi[:, 0], "rdot": np.zeros(B)})


def _sets(x: np.ndarray, B: int) -> tuple[list[np.ndarray], list[dict[str, np.ndarray]]]:
    xs, inits = [], []
    for j in range(len(x)):  # each parameter perturbed alone (steps of all signs and sizes)
        x1 = x.copy()
        x1[j] += (-1) ** j * 1e-3 * (j + 1)
        xs.append(x1)
        inits.append({"r": np.zeros(B), "psi": np.zeros(B)})
    xs.append(x.copy())  # the initial states perturbed
    inits.append({"r": np.full(B, 0.01), "psi": np.linspace(-0.1, 0.1, B)})
    return xs, inits


def test_simulate_sets_equals_one_simulation_per_set():
    win = _windows()
    B = win.batch_size
    prob = OEProblem(NOMOTO1, {}, win, ("psi", "r"))
    x = prob.fit_values({"K": 0.3, "T": 4.0, "delta0": 0.01})
    xs, inits = _sets(x, B)
    bad = x.copy()
    bad[1] = -1.0  # T < 0: no valid model; its set is marked, the others unaffected
    xs.insert(1, bad)
    inits.insert(1, inits[0])
    sims, ok = prob.simulate_sets(xs, inits)
    assert ok.tolist() == [True, False] + [True] * (len(xs) - 2)
    for k, (xk, ik) in enumerate(zip(xs, inits, strict=True)):
        if not ok[k]:
            continue
        one = prob.simulate(xk, ik)
        for c in ("psi", "r"):
            assert sims[c].shape == (len(xs), B, win.width)
            # the same lane arithmetic whatever the lane's place in the batch (each lane's
            # step depends on its own rows only): equal to rounding, 1e-13 relative allowing
            # for a lane computed in a vectorised loop's body in one call and its scalar
            # remainder in the other
            np.testing.assert_allclose(sims[c][k], one[c], rtol=1e-13, atol=1e-15)


def test_batched_jacobian_equals_one_simulation_per_parameter():
    win = _windows()
    B = win.batch_size
    prob = OEProblem(NOMOTO1, {}, win, ("psi", "r"))
    x0 = prob.fit_values({"K": 0.3, "T": 4.0, "delta0": 0.01})
    nf, ni = len(x0), 2
    x = np.concatenate([x0, win.init["r"], win.init["psi"]])
    hi = np.array([np.inf, 4.0 + 1e-9, np.inf])  # T at its upper bound: a backward step

    def unpack(x):
        return x[:nf], {"r": x[nf:nf + B], "psi": x[nf + B:]}

    def by_window(sim):  # (B, M) residuals, windows first
        return np.concatenate([sim[c][:, 1:] - win.outputs[c][:, 1:] for c in ("psi", "r")],
                              axis=1)

    def one_by_one(xs):
        return [by_window(prob.simulate(*unpack(x1))) for x1 in xs]

    def batched(xs):
        sims, ok = prob.simulate_sets(*zip(*[unpack(x1) for x1 in xs], strict=True))
        assert ok.all()
        return [by_window({c: sims[c][k] for c in ("psi", "r")}) for k in range(len(xs))]

    f0 = one_by_one([x])[0]
    G1, L1 = fd_jacobian(one_by_one, x, f0, nf, ni, hi)
    G2, L2 = fd_jacobian(batched, x, f0, nf, ni, hi)
    assert G1.shape == (B, 2 * (win.width - 1), nf) and L1.shape[-1] == ni
    # a difference of outputs equal to rounding (1e-13 relative, above) over a step of
    # sqrt(eps) relative: the columns agree to ~1e-13 * |y| / (1.5e-8 |x|), i.e. 1e-5 of a
    # column's scale at most; in practice identical
    for a, b in ((G1, G2), (L1, L2)):
        scale = np.max(np.abs(a), axis=(0, 1))
        assert np.all(np.max(np.abs(a - b), axis=(0, 1)) <= 1e-5 * scale + 1e-12)
    # the backward step at the bound: K's and T's columns both finite and non-zero
    assert np.all(np.isfinite(G2)) and np.all(np.max(np.abs(G2), axis=(0, 1))[:2] > 0)


def test_one_thread_pool_per_process(monkeypatch):
    import numba

    if numba.config.NUMBA_NUM_THREADS < 2:  # one thread: no pool is started at all
        return
    win = _windows(B=70)  # three chunks of lanes
    prob = OEProblem(NOMOTO1, {}, win, ("psi", "r"))
    x = prob.fit_values({"K": 0.3, "T": 4.0, "delta0": 0.01})
    prob.simulate(x)
    pool = core._pool()
    for _ in range(3):
        prob.simulate(x)
    assert core._pool() is pool
    # a forked child (another process id) starts its own pool, never the parent's object
    monkeypatch.setattr(core, "_POOL", dict(core._POOL))  # (this process's, restored after)
    monkeypatch.setattr(core.os, "getpid", lambda: -1)
    assert core._pool() is not pool


def test_mmg_sets_from_one_packed_row_equal_sets_built_anew():
    """MMG: a Jacobian's sets that perturb one hull coefficient (or the asymmetry) take the
    kept model's packed rows with that row set (``ModelKind.packed_row``); their outputs equal
    those of the sets built, validated and packed anew (a fresh problem, one set per call),
    and a set out of its parameter's bounds is still marked not ok."""
    from usvid.models.kinds.mmg import KIND, from_physics
    from usvid.models.kinds.mmg import physics as mmg

    rng = np.random.default_rng(3)
    B, W, h = 6, 81, 0.25
    t = np.arange(W) * h
    delta = math.radians(20) * np.sign(np.sin(0.1 * t[None, :] + rng.uniform(0, 6, (B, 1))))
    u0 = np.full(B, 1.1)
    z = np.zeros((B, W))
    win = Windows(h=h, inputs={"delta": delta, "n": np.full((B, W), 10.23)},
                  outputs={"u": z + 1.1, "v": z, "r": z, "psi": z},
                  init={"u": u0, "v": np.zeros(B), "r": np.zeros(B), "psi": np.zeros(B)})
    d = from_physics(mmg.kvlcc2("hsva"))
    fixed = {k: v for k, v in d.values().items() if k not in type(d).fit_names()}
    start = {k: getattr(d, k) for k in type(d).fit_names()}
    ch = ("u", "v", "r", "psi")
    prob = OEProblem(KIND, fixed, win, ch)
    x = prob.fit_values(start)
    prob.simulate(x, None)  # the kept model the perturbed sets start from
    xs, inits = [], []
    for j, n in enumerate(prob.names):
        if n in prob.held:  # (the twin PWM map's asymmetry: held for this variant)
            continue
        x1 = x.copy()
        x1[j] += 1e-6 * max(1.0, abs(x1[j]))
        xs.append(x1)
        inits.append(None)
    bad = x.copy()
    bad[prob.names.index("Y_P0")] = 0.9  # outside [-0.5, 0.5]
    xs.append(bad)
    inits.append(None)
    built = []
    prob.dynamics = lambda params: built.append(params) or OEProblem.dynamics(prob, params)
    sims, ok = prob.simulate_sets(xs, inits)
    assert ok.tolist() == [True] * (len(xs) - 1) + [False]
    # built anew: only R_0's set (without a nominal shaft speed R_0 moves the equilibrium one)
    assert len(built) == 1 and built[0]["R_0"] == xs[prob.names.index("R_0")][0]
    for k in range(len(xs) - 1):
        one = OEProblem(KIND, fixed, win, ch).simulate(xs[k], None)
        for c in ch:
            # the same rows bit for bit; 1e-13 relative as above for the lane's place
            np.testing.assert_allclose(sims[c][k], one[c], rtol=1e-13, atol=1e-15)
