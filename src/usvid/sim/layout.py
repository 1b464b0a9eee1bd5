"""The named rows of the integration core, and the code generated from a kind's state names.

A chunk of lanes keeps every quantity of its lanes in one work array ``V``: row ``R`` of lane
slot ``j`` is ``V[R * CH + j]`` (:data:`CH` lanes per chunk). The rows, in this order:

* the logic variables (:data:`LOGIC`, rows ``VL + L...``), the servo values (:data:`SERVO`),
  the command in force, the ramp rate and the step's noise sample, the first-order-hold input
  series at the step's two ends (:data:`SERIES_ROWS`), the trig bases (:data:`TRIG_ROWS`), the
  held environment loads and the hold's control row (:data:`HOLD_ROWS`, :data:`HOLD_CTRL`): the
  same rows for every kind;
* the joint state (:func:`joint_names`): x, y, psi, the servo angle and rate, the disturbance
  filter (w1, w2), then the kind's own states, by name;
* the kind's packed parameters, and scratch rows (the joint state before the vector step, the
  per-lane step's result).

The chunk driver (:mod:`usvid.sim.chunk`) is the same for every kind: it reads a kind's rows
at run time (:data:`KINFO`); the kind's own code (the per-lane step, the vector step) has them
as compile-time constants.

A lane's joint state is a tuple in the order of its rows (position ``i`` is row ``VZ + i``), so
that the helpers that load, store and combine it (:func:`joint_helpers`: one line per state,
for RK4) are generated from the kind's state names instead of being written by hand for a
fixed number of states.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

# ---------------------------------------------------------------------------------------------
# constants of the integration core
# ---------------------------------------------------------------------------------------------
#: Recorded channels in this order (``slots[i]``: row of channel i in ``rec``, or -1).
CHANNELS = ("x", "y", "psi", "u", "v", "r", "U", "delta", "delta_cmd", "n", "n_port", "n_stbd",
            "dist", "phi", "p")
NCH = len(CHANNELS)
#: Channels read from a kind state of the same name (roll angle [rad], roll rate [rad/s]):
#: recorded for the kinds that have them.
STATE_CHANNELS = ("phi", "p")
#: Logic codes.
COMMANDED, TURNING, ZIGZAG, COURSE = 0, 1, 2, 3
#: First-order-hold input series (rows ``VF + i`` at the step start, ``VF + NSER + i`` at its
#: end): the measured rudder angle [rad], shaft speed n [rps], thruster commands n_port, n_stbd
#: (absent: NaN, the servo's angle and the kind's nominal); the environment: the external force
#: on the hull in body axes X, Y [N], K, N [N m], the current's velocity over ground, north
#: and east [m/s], and the true wind as the air's velocity over ground, north and east [m/s]
#: (a wind from the north moves the air south: wind_x < 0) (absent: 0, calm water).
SERIES = ("delta", "n", "n_port", "n_stbd", "force_X", "force_Y", "force_K", "force_N",
          "current_x", "current_y", "wind_x", "wind_y")
NSER = len(SERIES)
#: Positions in :data:`SERIES` of the external force (X, Y, K, N), of the current (north,
#: east) and of the wind (north, east); the series before :data:`SFORCE` are absent as NaN,
#: the others as 0.
SFORCE, SCUR, SWIND = 4, 8, 10
#: The per-lane environment block of a batch with a state-dependent environment (wind loads,
#: mean wave drift), rows after the kind's own parameters: the packed wind-load model
#: (:data:`usvid.models.environment.wind_loads.WIND_PACK` entries, code 0: none), then the
#: mean wave drift's coefficients fx0, fy0 [N] and the cosine and sine of the direction chi the
#: waves travel towards (:func:`usvid.models.environment.waves.mean_drift_cs`; fx0 = fy0 = 0:
#: none; cos and sin, not chi, so that the vector step calls no library function).
NWIND = 16
ENVBLOCK = ("wind",) * NWIND + ("drift_fx0", "drift_fy0", "drift_cos_chi", "drift_sin_chi")
NENV = len(ENVBLOCK)
#: Zig-zag overshoots tracked online.
N_ZZ = 8
#: Seed disturbance filter 0.42 s / (s^2 + 0.36 s + 0.37) (Mu et al. 2018, section 6.1).
DIST_B, DIST_A1, DIST_A0 = 0.42, 0.36, 0.37
#: Largest |r| [rad/s] before a lane is declared diverged.
R_MAX = 100.0
#: The external force passed to the kind's right-hand side in calm water: (X, Y, K, N) all
#: -0.0, so that the kind's ``+ f[i]`` vanishes at compile time (x + -0.0 is x for every x).
NOF = (-0.0, -0.0, -0.0, -0.0)

#: Lanes per chunk (the row length of the chunk's work arrays; a compile-time constant so that
#: LLVM sees the rows of ``V`` as one object at constant offsets and vectorises the lane loop).
CH = 32

#: Logic-variable rows (row ``VL + i``): the command logged, the ideal servo's ramp end time, the
#: zig-zag sign and heading reference, the reversals so far, the PID integral, ITAE, IAE,
#: max |delta|, the dead-time queue's head and length, the overshoot so far, the noise standard
#: deviation, the time up to which the lane is quiet, the zig-zag switching angle, the lane's
#: quiet flag of the step and its slow-path flag, the lane's active flag and its number of steps.
LOGIC = ("cmdlog", "rend", "cur", "psi0", "zzn", "integ", "itae", "iae", "maxd", "qh", "qn",
         "ovmax", "esd", "tq", "sw", "q", "flag", "act", "ns")
#: Servo rows (:func:`usvid.sim.simulate.servo_rows`): max angle, max rate, T or omega_n, zeta,
#: gain, dead time [s], 1/T.
SERVO = ("max_angle", "max_rate", "t_or_wn", "zeta", "gain", "delay", "inv_t")
#: Input-series rows: :data:`SERIES` at the step start, then at the step end.
SERIES_ROWS = 2 * NSER
#: Trig-base rows: heading angle, cos, sin; steering angle, cos, sin (at the step start).
TRIG_ROWS = 6
#: Held-load rows of a batch with wind loads or wave drift (the multirate hold,
#: :func:`usvid.sim.lane._heldrows`): the loads X, Y, K, N of the last evaluation, their rates
#: [per s] from the evaluation before, and the step index of the last evaluation; both paths
#: (per-lane, vector) read and write these rows, so that a lane's loads do not depend on which
#: path ran a step.
HOLD_ROWS = 9
#: The hold's control row (slots 0-3, the same for every lane of a chunk, written by the
#: driver at every step): 1 when the loads are evaluated at this step's start (else 0), the
#: step index, the time [s] from the last evaluation to the step's midpoint times the
#: extrapolation's weight (0: a zero-order hold), and the weight over the evaluation
#: interval [1/s] (0 at the first evaluation: no rate yet).
HOLD_CTRL = ("refresh", "step", "offset", "rate_scale")

SERVO_ROWS = len(SERVO)

(LCMDLOG, LREND, LCUR, LPSI0, LZZN, LINTEG, LITAE, LIAE, LMAXD, LQH, LQN, LOVMAX, LESD, LTQ,
 LSW, LQ, LFLAG, LACT, LNS) = range(len(LOGIC))
NL = len(LOGIC)
VL = 0
VS = VL + NL
VCMD = VS + len(SERVO)
VRAMP = VCMD + 1
VNOISE = VRAMP + 1
VF = VNOISE + 1
VT = VF + SERIES_ROWS
#: First held-load row (:data:`HOLD_ROWS`) and the hold's control row (:data:`HOLD_CTRL`).
VH = VT + TRIG_ROWS
VC = VH + HOLD_ROWS
#: First row of the joint state.
VZ = VC + 1

#: The joint state's rows common to every kind (positions in the lane's tuple), then the kind's
#: states from position :data:`JS`.
COMMON = ("x", "y", "psi", "delta", "delta_dot", "w1", "w2")
JX, JY, JPSI, JDL, JDD, JW1, JW2 = range(len(COMMON))
JS = len(COMMON)
#: Their rows in ``V`` (row ``VZ + J..``); the kind's states from row :data:`RS`.
RX, RY, RPSI, RDL, RDD, RW1, RW2 = (VZ + i for i in range(len(COMMON)))
RS = VZ + JS


def joint_names(states: Sequence[str]) -> tuple[str, ...]:
    """The joint state's names in tuple (and row) order: :data:`COMMON`, then the kind's."""
    return COMMON + tuple(f"s:{s}" for s in states)


#: What the kind-independent chunk driver reads of a kind at run time (rows of the kind's
#: ``kinfo`` array, :meth:`Layout.kinfo`): its number of states and parameters, the joint-state
#: length, the rows of the parameters, the scratch and the per-lane result, the rows in all, the
#: joint-state positions of u, v, r, phi, p (-1: none; u -1: the constant speed of the
#: parameter row ``speed_row``, v -1: zero), and whether it reads cos/sin of the steering angle.
KINFO = ("ns", "npk", "nt", "vp", "vb", "vn", "rows", "zu", "zv", "zr", "zphi", "zp",
         "speed_row", "trig")
(KNS, KNPK, KNT, KVP, KVB, KVN, KROWS, KZU, KZV, KZR, KZPHI, KZP, KSPEED, KTRIG) = range(len(KINFO))


@dataclass(frozen=True)
class Layout:
    """The rows of a kind's chunk work array: ``ns`` states, ``npk`` packed parameters.

    ``nt`` joint-state length, ``vp`` first parameter row, ``vb`` first scratch row (the joint
    state and overshoot before the vector step, then its new max |delta| and overshoot),
    ``vn`` first row of the per-lane step's result (the joint state), ``rows`` the total."""

    ns: int
    npk: int

    @property
    def nt(self) -> int:
        return JS + self.ns

    @property
    def vp(self) -> int:
        return VZ + self.nt

    @property
    def vb(self) -> int:
        return self.vp + self.npk

    @property
    def vn(self) -> int:
        return self.vb + self.nt + 3

    @property
    def rows(self) -> int:
        return self.vn + self.nt

    def constants(self) -> dict[str, int]:
        """The kind-dependent constants the kind's templates read as globals."""
        return {"NS": self.ns, "NPK": self.npk, "NT": self.nt, "VP": self.vp, "VB": self.vb,
                "VN": self.vn, "VROWS": self.rows}

    def kinfo(self, *, zu: int, zv: int, zr: int, zphi: int, zp: int, speed_row: int,
              trig: bool) -> tuple[int, ...]:
        """The values of :data:`KINFO` (positions ``z..`` in the joint-state tuple)."""
        return (self.ns, self.npk, self.nt, self.vp, self.vb, self.vn, self.rows, zu, zv, zr,
                zphi, zp, speed_row, int(trig))


# ---------------------------------------------------------------------------------------------
# generated helpers
# ---------------------------------------------------------------------------------------------
def _function(name: str, args: str, lines: Sequence[str], g: Mapping[str, Any]) -> Any:
    """A Python function ``name(args)`` with the body ``lines`` and the globals ``g`` (compiled
    with this module's file name, so that tracebacks and numba's messages point here)."""
    src = f"def {name}({args}):\n" + "".join(f"    {line}\n" for line in lines)
    ns: dict[str, Any] = {}
    exec(compile(src, __file__, "exec"), dict(g), ns)  # noqa: S102 - generated from names
    return ns[name]


def _tuple(items: Sequence[str]) -> str:
    return "(" + ", ".join(items) + ("," if len(items) == 1 else "") + ")"


def joint_helpers(layout: Layout, g: Mapping[str, Any], *, xy: bool = True,
                  nod: bool = False) -> dict[str, Any]:
    """The functions that handle a lane's joint-state tuple for ``layout`` (plain Python; the
    caller compiles them), by name:

    * ``_ztup(V, j)``: the tuple from the rows VZ.. of lane slot j; ``_zput(A, o, z)``: stores
      it at ``A[o + i * CH]`` (o = row * CH + j);
    * ``_states(z)``: the kind's states; ``_joint(k0, k1, k2, rate, acc, k5, k6, ds)``: a
      derivative tuple from the kinematics, the servo, the filter and the kind's ``ds``;
    * ``_with_dl(z, d)``: z with the servo angle d (``_with_servo(z, d, dd)``: and rate dd);
      ``_finite(z)``: every position, heading
      and kind state finite (bitwise ``&``: no branch; by ``_fin``, which the caller's
      globals hold: :func:`usvid.sim.scalar._fin`);
    * ``_axpy(z, h, k)``: z + h k; ``_rk4sum(z, h6, k1, k2, k3, k4)``: the RK4 combination;
    * for the vector step (variant ``xy``: x and y integrated; ``nod``: no disturbance filter),
      ``_vaxpy`` and ``_vrk4sum(z, h6, k1, k2, k3, k4, far)`` keeping the rows the variant
      does not integrate (and psi NaN where ``far``), ``_vput(V, j, y, dl, dd)`` storing its
      result.
    """
    nt = layout.nt
    rng = range(nt)
    rk = "z[{i}] + h6 * (k1[{i}] + 2.0 * k2[{i}] + 2.0 * k3[{i}] + k4[{i}])"

    def kept(i: int) -> bool:  # a row the vector variant leaves as it is
        return (not xy and i in (JX, JY)) or (nod and i in (JW1, JW2))

    fs = {
        "_ztup": ("V, j", [f"return {_tuple([f'V[{(VZ + i) * CH} + j]' for i in rng])}"]),
        "_zput": ("A, o, z", [f"A[o + {i * CH}] = z[{i}]" for i in rng]),
        "_states": ("z", [f"return {_tuple([f'z[{JS + i}]' for i in range(layout.ns)])}"]),
        "_joint": ("k0, k1, k2, rate, acc, k5, k6, ds", [
            "return " + _tuple(["k0", "k1", "k2", "rate", "acc", "k5", "k6"]
                               + [f"ds[{i}]" for i in range(layout.ns)])]),
        "_with_dl": ("z, d", [f"return {_tuple(['d' if i == JDL else f'z[{i}]' for i in rng])}"]),
        "_with_servo": ("z, d, dd", [f"return {_tuple(['d' if i == JDL else 'dd' if i == JDD else f'z[{i}]' for i in rng])}"]),  # noqa: E501
        "_finite": ("z", ["return " + " & ".join(  # (not np.isfinite: usvid.sim.scalar._fin)
            f"_fin(z[{i}])" for i in rng if i in (JX, JY, JPSI) or i >= JS)]),
        "_axpy": ("z, h, k", [f"return {_tuple([f'z[{i}] + h * k[{i}]' for i in rng])}"]),
        "_rk4sum": ("z, h6, k1, k2, k3, k4", [
            f"return {_tuple([rk.format(i=i) for i in rng])}"]),
        "_vaxpy": ("z, h, k", [f"return {_tuple([f'z[{i}]' if kept(i) else f'z[{i}] + h * k[{i}]' for i in rng])}"]),  # noqa: E501
        "_vrk4sum": ("z, h6, k1, k2, k3, k4, far", [
            f"y{JPSI} = {rk.format(i=JPSI)}",
            "return " + _tuple([f"z[{i}]" if kept(i) else ("np.nan if far else y2" if i == JPSI
                                                            else rk.format(i=i)) for i in rng])]),
        "_vput": ("V, j, y, dl, dd", [
            f"V[{(VZ + i) * CH} + j] = " + ("dl" if i == JDL else "dd" if i == JDD else f"y[{i}]")
            for i in rng if not kept(i)]),
    }
    return {name: _function(name, args, lines, g) for name, (args, lines) in fs.items()}


def param_tuple(layout: Layout, g: Mapping[str, Any],
                const: Mapping[int, float] | None = None) -> Any:
    """``_ptup(V, j)``: lane slot j's parameter tuple from the rows VP.., the rows of ``const``
    replaced by literals (compile-time constants: a switch value's vector step)."""
    const = const or {}
    items = [repr(float(const[i])) if i in const else f"V[{(layout.vp + i) * CH} + j]"
             for i in range(layout.npk)]
    return _function("_ptup", "V, j", [f"return {_tuple(items)}"], g)


def env_tuple(layout: Layout, g: Mapping[str, Any], *, read: bool,
              const: Mapping[int, float] | None = None) -> Any:
    """``_etup(V, j)``: lane slot j's environment block (:data:`ENVBLOCK`) from the rows after
    the kind's parameters (``read``: a batch with wind loads or wave drift, whose chunk array
    has :data:`NENV` more parameter rows), else zeros (literals: compiled away); the rows of
    ``const`` replaced by literals (the wind-load model's code in a vector-step variant: the
    other model's branch compiled away)."""
    const = const or {}
    items = [repr(float(const[i])) if i in const else
             f"V[{(layout.vp + layout.npk + i) * CH} + j]" if read else "0.0"
             for i in range(NENV)]
    return _function("_etup", "V, j", [f"return {_tuple(items)}"], g)
