"""The model-kind contract: what every kind module of :mod:`usvid.models.kinds` declares.

A kind is one module holding

* a parameter-set dataclass (subclass of :class:`Dynamics`) whose fields are declared with
  :func:`param` (unit, bounds, one-line meaning, whether identification estimates it) or
  :func:`submodel` (a nested model such as a thrust law);
* its named states (``states``, any number up to the generous bound :data:`MAX_STATES`; the
  core generates the joint state's rows and their packing from the names);
* one numba right-hand side ``rhs(p, s, a, f)`` returning ``(u, v, r, ds)`` (see
  :class:`ModelKind`), the only copy of the kind's equations of motion, integrated by
  :mod:`usvid.sim.core` for simulation and for every identification method;
* ``pack`` (parameters -> the flat rows the right-hand side reads), ``initial`` (the kind's
  states from the measured yaw rate / velocities), and, where the kind has one, its
  linear-in-parameters :class:`Regression` form with the map between regression coefficients
  and parameters;
* ``KIND = ModelKind(...)``, which the registry (:mod:`usvid.models.registry`) finds.

The model-file schema, the CLI's ``--model`` choices, the README's kind table and the estimators
are driven by these declarations; adding a kind is adding one module (and its tests).

``pack`` returns parameters as (n_params, lanes) and ``initial`` states as (n_states, lanes); a
lane is one simulated run (or one output-error window). The joint state of the core holds x, y,
psi, then the kind's states from position ``S0``.

A state named ``phi`` is the roll angle [rad, positive = heel to starboard] and ``p`` the roll
rate [rad/s]: the simulator records them (channels ``phi``, ``p``) and the standard runs report
the largest heel (:mod:`usvid.sim.runs`), for every kind that has them.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from usvid.errors import UsvidError
from usvid.models._validate import _show

#: Row of the first kind state in the joint state of the core (rows 0-2: x, y, psi).
S0 = 3
#: Most states a kind may have: a generous bound, not a layout (the core generates its rows from
#: the kind's state names; a lane's joint state is a tuple of ``7 + n_states`` floats kept in
#: registers, and the compile time grows with its length).
MAX_STATES = 16
#: Most packed parameter values of a kind (the length of the right-hand side's tuple; mmg
#: uses 66).
MAX_PARAMS = 80
#: Actuator inputs a kind may read (``ModelKind.inputs``).
INPUTS = ("delta", "n", "n_port", "n_stbd")
#: The actuator tuple ``a`` of the right-hand side, in this order: the effective steering angle
#: delta [rad], its cosine and sine, the shaft speed n [rps] and the thruster commands n_port,
#: n_stbd (NaN: the kind's nominal).
ACTUATORS = ("delta", "cos_delta", "sin_delta", "n", "n_port", "n_stbd")
#: The external generalised force ``f`` of the right-hand side, body axes, about the body
#: origin: surge X [N], sway Y [N], roll moment K [N m], yaw moment N [N m] (wind, waves; zero
#: in calm water).
FORCES = ("X", "Y", "K", "N")


class _Required:
    """The default of a required parameter (``ParamSpec.default``)."""

    def __repr__(self) -> str:
        return "REQUIRED"


REQUIRED: Any = _Required()


# ---------------------------------------------------------------------------------------------
# parameter declarations
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ParamSpec:
    """One parameter of a kind: ``name``, SI ``unit``, one-line ``meaning``, bounds
    (``gt``/``ge``/``lt``/``le``, None when open), ``fit`` (estimated by identification rather
    than carried from the vessel particulars), ``default`` (:data:`REQUIRED` when required),
    ``submodel`` (the family of a nested model, e.g. ``"thrust"``; None for a number)."""

    name: str
    unit: str
    meaning: str
    gt: float | None = None
    ge: float | None = None
    lt: float | None = None
    le: float | None = None
    fit: bool = True
    default: Any = REQUIRED
    submodel: str | None = None

    @property
    def required(self) -> bool:
        return self.default is REQUIRED

    def check(self, owner: str, value: Any) -> None:
        """Raise :class:`UsvidError` naming ``owner.name`` when ``value`` (scalar or batch array)
        is not finite or out of bounds."""
        if isinstance(value, (int, float)):  # a number within bounds: no array to build
            v = float(value)
            if math.isfinite(v) and (self.gt is None or v > self.gt) \
                    and (self.ge is None or v >= self.ge) and (self.lt is None or v < self.lt) \
                    and (self.le is None or v <= self.le):
                return
        arr = np.asarray(value, dtype=float)
        where = f"{owner}.{self.name}"
        if not np.all(np.isfinite(arr)):
            raise UsvidError(f"{where} must be a finite number (got {_show(arr)})")
        for op, v, ok in (("> ", self.gt, np.greater), (">= ", self.ge, np.greater_equal),
                          ("< ", self.lt, np.less), ("<= ", self.le, np.less_equal)):
            if v is not None and not np.all(ok(arr, v)):
                raise UsvidError(f"{where} must be {op}{v:g} (got {_show(arr, ~ok(arr, v))})")


def param(unit: str, meaning: str, *, default: Any = REQUIRED,
          gt: float | None = None, ge: float | None = None, lt: float | None = None,
          le: float | None = None, fit: bool = True) -> Any:
    """A numeric parameter field (a float, or a (B,) array for a batch of parameter sets)."""
    spec = dict(unit=unit, meaning=meaning, gt=gt, ge=ge, lt=lt, le=le, fit=fit, default=default)
    if default is REQUIRED:
        return field(metadata={"usvid": spec})
    return field(default=default, metadata={"usvid": spec})


def submodel(family: str, meaning: str, *, default: Any = None) -> Any:
    """A nested sub-model field (e.g. ``family="thrust"``: a number [N] or a thrust law
    dataclass of :mod:`usvid.models.thrust`); never estimated by identification."""
    spec = dict(unit="", meaning=meaning, fit=False, default=default, submodel=family)
    return field(default=default, metadata={"usvid": spec})


_SPECS: dict[type, tuple[ParamSpec, ...]] = {}  # Dynamics.param_specs by class


class Dynamics:
    """Base class of the parameter-set dataclasses of the kinds (validated on construction).

    Every field declared with :func:`param` is checked against its bounds (scalars or (B,)
    arrays: a batch of parameter sets); the message names the parameter, e.g.
    ``parameters.T must be > 0 (got -1.2)``.
    """

    kind: ClassVar[str] = ""

    def __post_init__(self) -> None:
        for spec in self.param_specs():
            if spec.submodel is None:
                v = getattr(self, spec.name)
                if v is None and spec.default is None:
                    continue  # an optional particular not given
                if np.ndim(v) > 1:
                    raise UsvidError(f"parameters.{spec.name} must be a number or a 1-D batch "
                                     f"array (got shape {np.shape(v)})")
                spec.check("parameters", v)
        self.validate()

    def validate(self) -> None:
        """Extra checks of a kind (relations between parameters); default none."""

    @classmethod
    def param_specs(cls) -> tuple[ParamSpec, ...]:
        """The declared parameters, in field order (made once per class: every construction
        checks them)."""
        specs = _SPECS.get(cls)
        if specs is None:
            specs = _SPECS[cls] = tuple(
                ParamSpec(name=f.name, **f.metadata["usvid"])
                for f in dataclasses.fields(cls)  # type: ignore[arg-type]
                if "usvid" in f.metadata)
        return specs

    @classmethod
    def fit_names(cls) -> tuple[str, ...]:
        """Names of the parameters identification estimates."""
        return tuple(p.name for p in cls.param_specs() if p.fit and p.submodel is None)

    @classmethod
    def example(cls) -> Dynamics:
        """A valid parameter set of this kind (every required parameter 1.0, optional ones
        at their defaults): for sizes and smoke tests."""
        kw = {p.name: 1.0 for p in cls.param_specs() if p.required}
        return cls(**kw)

    def values(self) -> dict[str, Any]:
        """Parameter name -> value (numbers and sub-models)."""
        return {p.name: getattr(self, p.name) for p in self.param_specs()}

    def replace(self, **changes: Any) -> Dynamics:
        """A copy with some parameters changed (validated again)."""
        return dataclasses.replace(self, **changes)  # type: ignore[type-var]


# ---------------------------------------------------------------------------------------------
# regression form
# ---------------------------------------------------------------------------------------------
@dataclass
class Block:
    """One equation of a regression form: ``y = Phi theta`` with coefficient ``names``;
    ``trial_rows`` the number of rows each trial contributes (for residual diagnostics)."""

    name: str
    Phi: np.ndarray
    y: np.ndarray
    names: tuple[str, ...]
    trial_rows: list[int] = field(default_factory=list)


class LeftOutWarning(UserWarning):
    """A regression left samples out (e.g. near rest); the message names the trial by its
    position ``trial i of N`` (1-based, in the order of the series), the time spans [s] and
    why; the estimator replaces the position by the trial's name."""


@dataclass(frozen=True)
class Regression:
    """The linear-in-parameters form of a kind (equation-error least squares).

    ``blocks(series, fixed, form, step) -> list[Block]``: the regression of every equation,
    stacked over the trials. ``series`` is a list of dicts of 1-D arrays on one uniform grid of
    step ``step`` [s] (channels of the Trial contract plus smoothed ``<name>_s`` and
    derivatives ``<name>dot_s``), ``fixed`` the parameters carried from the vessel particulars
    (thrust law, lever arm, ...), ``form`` one of ``forms``.

    ``to_params(theta, fixed, form, h) -> dict``: parameters of the fitted coefficients
    (``theta``: coefficient name -> value). When the form has more coefficients than the kind
    has free parameters (``constrained``), ``coefficients(params, fixed, form, h) -> dict`` maps
    parameters back and the estimator refines the parameters on the stacked equation errors, so
    that the identified parameters satisfy every equation (no coefficient is dropped).
    """

    blocks: Callable[[Sequence[Mapping[str, np.ndarray]], Mapping[str, Any], str, float],
                     list[Block]]
    to_params: Callable[[Mapping[str, float], Mapping[str, Any], str, float], dict[str, float]]
    coefficients: Callable[[Mapping[str, float], Mapping[str, Any], str, float],
                           dict[str, float]] | None = None
    forms: tuple[str, ...] = ("continuous",)
    needs: tuple[str, ...] = ()
    #: ``priors(series, fixed) -> dict``: the physical priors of the fitted parameters (what a
    #: regularised regression pulls towards); the output error starts from them when the
    #: regression's estimate is not a valid model. None: the kind has none.
    priors: Callable[[Sequence[Mapping[str, np.ndarray]], Mapping[str, Any]],
                     dict[str, float]] | None = None
    #: ``external(vessel, options) -> str | None`` when ``blocks`` takes known external loads
    #: (series :data:`EXTERNAL`: X, Y [N], N [N m], body axes: the logged wind's, which
    #: the regression subtracts and the output error simulates): why the kind's forces are not
    #: in newtons for these particulars (a thrust in command units: no load in newtons can be
    #: added to them), None when they are. None: the regression takes no external loads.
    external: Callable[[Any, Mapping[str, Any]], str | None] | None = None

    @property
    def constrained(self) -> bool:
        return self.coefficients is not None


#: Series of known external loads along a measured track that a regression takes
#: (``Regression.external``): X, Y [N], N [N m], body axes (the logged wind's,
#: :func:`usvid.identify.wind.track_wind_loads`).
EXTERNAL = ("ext_X", "ext_Y", "ext_N")


def in_newtons(vessel: Any, options: Mapping[str, Any]) -> None:
    """``Regression.external`` of a kind whose forces are in newtons whatever its particulars
    (a physical thrust law): known external loads can always be added to them."""
    return None


@dataclass(frozen=True)
class FitSpace:
    """A reparametrisation used by output error (optimisers see ``to_fit(params)``; the model
    file holds ``from_fit(x)``): e.g. Norrbin's T = 1 normalisation, in which the linear term
    passes continuously through 0 between course-stable and course-unstable. Both map
    name -> value dicts over :meth:`Dynamics.fit_names`; ``names`` are the fit-space names and
    ``held`` those kept at their start value."""

    names: tuple[str, ...]
    to_fit: Callable[[Mapping[str, float]], dict[str, float]]
    from_fit: Callable[[Mapping[str, float]], dict[str, float]]
    held: tuple[str, ...] = ()
    #: Lower bounds of fit-space values (e.g. an inverse mass > 0): the equation-error fit of a
    #: constrained form stays above them (a negative mass is never returned), starting from
    #: ``fallback[name]`` where the unconstrained estimate breaks the bound.
    lower: Mapping[str, float] = field(default_factory=dict)
    fallback: Mapping[str, float] = field(default_factory=dict)


# ---------------------------------------------------------------------------------------------
# the kind descriptor
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ModelKind:
    """Everything the registry, the core, the model file and the estimators know of a kind.

    Attributes
    ----------
    name, title, equation, reference : str
        ``--model`` name, a title, the equations in one line (README table), the source.
    dynamics : type[Dynamics]
        The parameter-set dataclass.
    states : tuple of str
        The kind's own states (rows ``S0 ..`` of the joint state), e.g. ``("r",)``; any number
        up to :data:`MAX_STATES`. ``phi`` [rad] and ``p`` [rad/s] name roll (recorded and
        measured generically, see the module docstring).
    body : tuple of 3 ints
        Rows (within ``states``) holding u, v, r, or -1: u is then the constant speed (row
        ``speed_row`` of P) and v is 0 (response models).
    speed_row : int
        Row of P holding the constant speed U [m/s] of a constant-speed kind (-1 otherwise).
    inputs : tuple of str
        Actuator inputs read (subset of :data:`INPUTS`).
    rhs : numba function
        ``rhs(p, s, a, f) -> (u, v, r, ds)``: from the lane's parameter tuple ``p`` (the values
        of ``pack``, at most :data:`MAX_PARAMS`), the kind's states ``s`` (a tuple in the order
        of ``states``), the actuators ``a`` (:data:`ACTUATORS`: the effective steering angle
        delta [rad] (servo + disturbance), its cosine and sine, the shaft speed n [rps] (NaN:
        the kind's nominal), the thruster commands n_port, n_stbd (NaN: from the steering angle
        and the nominal command)) and the external force ``f`` (:data:`FORCES`: X, Y [N], K,
        N [N m], body axes; zero in calm water): the velocities the kinematics integrate
        (``x' = u cos psi - v sin psi``, ``y' = u sin psi + v cos psi``, ``psi' = r``; u, v
        [m/s], r [rad/s]; a roll kind returns ``v cos phi`` and ``r cos phi``) and the time
        derivatives ``ds`` of the states (a tuple, the order of ``states``). Tuples and scalars
        only: the core keeps a lane's state in registers.
    pack : callable ``(dynamics, speed) -> (n_params, B) array``
        The parameter rows (with derived constants) for the core; ``speed`` [m/s] (scalar or
        (B,)) is the approach speed (the constant speed of response kinds).
    initial : callable ``(dynamics, values) -> (n_states, B) array``, optional
        The kind's states from measured ``values`` (``u``, ``v``, ``r`` [SI], ``rdot``,
        ``delta`` [rad], scalars or (B,) arrays; absent ones 0). Default: each state the value
        of its own name.
    speed : callable ``(dynamics) -> float or (B,) array``, optional
        Straight-line speed [m/s] under the nominal inputs (None for constant-speed kinds).
    outputs : tuple of str
        Measured channels output error compares (and whose initial values it estimates).
    regression : Regression, optional
    fit_space : FitSpace, optional
    particulars : callable ``(vessel, trials, options) -> dict``, optional
        The non-fitted parameters (thrust law, lever arm, nominal command, ...) from the
        trials' vessel particulars, the trials themselves and user options; raises
        :class:`usvid.errors.IdentificationError` naming what is missing and where to give it.
    series : callable ``(series_dict, fixed) -> None``, optional
        Adds kind-specific regressors to a trial's series (e.g. forces from the thrust law).
    channels : callable ``(dynamics, rec) -> None``, optional
        Fills recorded input channels the kind derives (e.g. thruster commands from delta).
    state_estimation : bool
        Identification takes u, v, r and their derivatives from the EKF + RTS smoother of
        :func:`usvid.prep.estimate_states` where the trials have positions (force-model kinds:
        the regression needs the sway velocity and accelerations, not just smoothed logs).
    transfer : callable ``(dynamics) -> (num, den)``, optional
        The yaw-rate transfer function r/delta (highest power first; linearised about r = 0)
        of a linear or linearisable response kind (:mod:`usvid.models.export`).
    packed_row : callable ``(dynamics, name) -> (row, factor) or None``, optional
        Where a fitted parameter ``name`` enters the packed rows of ``dynamics`` alone: the
        row ``row`` of ``pack`` holds ``factor * value`` and no other row, nor the kind's
        ``initial`` map, nor a validity check beyond the parameter's own bounds depends on
        it (given the other parameters of ``dynamics``); None where that does not hold. Output
        error then sets that row of a perturbed parameter set instead of building and packing
        the set anew (:meth:`usvid.identify.output_error.OEProblem.simulate_sets`). Default:
        every set built anew.
    switch_row, switch_values : int, tuple of float
        A row of the packed parameters that selects a branch of ``rhs`` (e.g. the thrust law's
        mode) and its most used values (at most 3): the core's vectorised step is compiled
        once more per value with that row a constant, so that it evaluates only that branch
        (lanes of other values take the generic vectorised step). -1: none.
    vector_interleave : int
        Lane vectors the core's vectorised step computes side by side (1: one at a time). A
        right-hand side whose square roots and divisions follow one another (the MMG kind's
        hull, wake and rudder inflow) makes one vector's RK4 step a chain of long-latency
        instructions that the processor cannot overlap with the next vector's (the step is
        thousands of instructions); two vectors in flight fill the gaps. A short right-hand
        side (the 3-DOF kind) gains nothing and loses registers: 1.
    """

    name: str
    title: str
    equation: str
    reference: str
    dynamics: type[Dynamics]
    states: tuple[str, ...]
    body: tuple[int, int, int]
    inputs: tuple[str, ...]
    rhs: Any
    pack: Callable[[Dynamics, Any], np.ndarray]
    outputs: tuple[str, ...]
    initial: Callable[[Dynamics, Mapping[str, Any]], np.ndarray] = None  # type: ignore[assignment]
    speed_row: int = -1
    speed: Callable[[Dynamics], Any] | None = None
    regression: Regression | None = None
    fit_space: FitSpace | None = None
    particulars: Callable[..., dict[str, Any]] | None = None
    series: Callable[[dict[str, np.ndarray], Mapping[str, Any]], None] | None = None
    channels: Callable[[Dynamics, dict[str, np.ndarray]], None] | None = None
    transfer: Callable[[Dynamics], tuple[list[float], list[float]]] | None = None
    packed_row: Callable[[Dynamics, str], tuple[int, float] | None] | None = None
    uses_trig: bool = False
    switch_row: int = -1
    switch_values: tuple[float, ...] = ()
    state_estimation: bool = False
    vector_interleave: int = 1
    source_hash: str = ""

    def __post_init__(self) -> None:
        if not 1 <= len(self.states) <= MAX_STATES:
            raise ValueError(f"kind {self.name}: 1 to {MAX_STATES} states")
        if len(set(self.states)) != len(self.states):
            raise ValueError(f"kind {self.name}: state names must be unique {self.states}")
        if self.vector_interleave not in (1, 2, 4):
            raise ValueError(f"kind {self.name}: vector_interleave 1, 2 or 4, not "
                             f"{self.vector_interleave}")
        bad = set(self.inputs) - set(INPUTS)
        if bad:
            raise ValueError(f"kind {self.name}: unknown inputs {sorted(bad)}")
        if self.initial is None:
            object.__setattr__(self, "initial", lambda d, values: rows(
                [values.get(s, 0.0) for s in self.states]))

    @property
    def constant_speed(self) -> bool:
        """True for the constant-speed yaw response models (u = U, v = 0)."""
        return self.body[0] < 0

    @property
    def n_states(self) -> int:
        return len(self.states)

    def state_row(self, name: str) -> int:
        """Position of the state ``name`` in ``states`` (-1 when the kind has none)."""
        return self.states.index(name) if name in self.states else -1

    @property
    def n_params(self) -> int:
        """Length of the packed parameter rows (and of the right-hand side's tuple)."""
        return int(self.pack(self.dynamics.example(), 1.0).shape[0])

    def derivatives(self, dynamics: Dynamics, states: Any, *, delta: Any = 0.0,
                    n: Any = math.nan, n_port: Any = math.nan, n_stbd: Any = math.nan,
                    speed: Any = 1.0, force: Any = (0.0, 0.0, 0.0, 0.0)
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The kind's right-hand side evaluated with numpy inputs (for checks by hand and
        plots; simulation integrates the same function in the core).

        ``states`` (..., n_states) the kind's states; ``delta`` [rad] the effective steering
        angle, ``n`` [rps], ``n_port``/``n_stbd`` commands (NaN: the kind's nominal), ``speed``
        [m/s] the constant speed of a response kind; all broadcast against ``states[..., 0]``;
        ``force`` the external force (X, Y [N], K, N [N m], body axes; :data:`FORCES`).
        Returns (u, v [m/s], r [rad/s], d states/dt (..., n_states)).
        """
        x = np.asarray(states, dtype=float)
        if x.shape[-1] != self.n_states:
            raise UsvidError(f"{self.name}: states must have {self.n_states} columns "
                             f"({', '.join(self.states)}), got shape {x.shape}")
        shape = np.broadcast_shapes(x.shape[:-1], np.shape(delta), np.shape(n),
                                    np.shape(n_port), np.shape(n_stbd))
        xs = np.broadcast_to(x, (*shape, self.n_states)).reshape(-1, self.n_states)
        ins = [np.broadcast_to(np.asarray(a, float), shape).ravel()
               for a in (delta, n, n_port, n_stbd)]
        P = self.pack(dynamics, speed)
        B = xs.shape[0]
        P = np.broadcast_to(P, (P.shape[0], max(B, P.shape[1])))
        f = tuple(float(v) for v in force)
        if len(f) != len(FORCES):
            raise UsvidError(f"{self.name}: force must be (X, Y, K, N), got {force!r}")
        uvr = np.empty((B, 3))
        dz = np.empty((B, self.n_states))
        for b in range(B):
            d = float(ins[0][b])
            a = (d, math.cos(d), math.sin(d), float(ins[1][b]), float(ins[2][b]),
                 float(ins[3][b]))
            u, v, r, ds = self.rhs(tuple(P[:, b if P.shape[1] > 1 else 0].tolist()),
                                   tuple(xs[b].tolist()), a, f)
            uvr[b] = (u, v, r)
            dz[b] = ds
        return (uvr[:, 0].reshape(shape), uvr[:, 1].reshape(shape), uvr[:, 2].reshape(shape),
                dz.reshape((*shape, self.n_states)))

    def table_row(self) -> str:
        """The README row: ``| name | equation | parameters (units) |``."""
        ps = []
        for p in self.dynamics.param_specs():
            unit = f" [{p.unit}]" if p.unit and p.unit != "-" else ""
            ps.append(f"`{p.name}`{unit}")
        return f"| `{self.name}` | {self.equation} | {', '.join(ps)} |"


def batch_size(values: Mapping[str, Any]) -> int:
    """The common batch size of scalar/(B,) values (1 when all are scalars)."""
    shapes = [np.shape(v) for v in values.values() if v is not None and not hasattr(v, "kind")]
    try:
        shape = np.broadcast_shapes(*shapes) if shapes else ()
    except ValueError as exc:
        raise UsvidError(f"batch parameters have incompatible lengths: {exc}") from None
    return int(shape[0]) if shape else 1


def inverse(value: Any) -> Any:
    """1 / value of an optional positive parameter (scalar or (B,)); 0 where it is None."""
    return 0.0 if value is None else 1.0 / np.asarray(value, dtype=float)


def rows(values: Sequence[Any], B: int | None = None) -> np.ndarray:
    """Stack scalars/(B,) arrays into a (len(values), B) float array."""
    if B is None:
        B = batch_size({str(i): v for i, v in enumerate(values)})
    out = np.empty((len(values), B))
    for i, v in enumerate(values):
        out[i] = np.broadcast_to(np.asarray(v, dtype=float), (B,))
    return out
