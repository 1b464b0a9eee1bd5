"""Model files (JSON, ``"usvid_model": 1``): validation, loading, saving.

Schema (``ARCHITECTURE.md``, "Model file")::

    {"usvid_model": 1, "kind": "norrbin",
     "parameters": {"K": 0.3, "T": 21.0, "n1": -0.19, "n3": 1180.0, "delta0": 0.0},
     "servo": {"kind": "first_order", "T": 0.0, "max_angle_deg": 35, "max_rate_deg_s": 15.8},
     "vessel": {"length": 7.0, "speed": 1.18},
     "identification": {"data": ["..."], "method": "...", "std_errors": {}, "fit": {}}}

* ``kind`` (a registered kind, :mod:`usvid.models.registry`) and its SI ``parameters``: the
  fields of the kind's parameter set, generated from its declarations (name, unit, bounds);
  sub-models such as ``thrust`` as a number or a nested ``{"kind": ...}`` object (see
  :func:`_thrust_to_dict`).
* ``servo.kind``: ``ideal``, ``first_order`` (T [s]), ``second_order`` (omega_n [rad/s], zeta,
  gain, delay [s]); each with ``max_angle_deg`` (default 35) and ``max_rate_deg_s`` (default
  none = unlimited; JSON has no infinity).
* ``vessel``: length [m], speed [m/s], optional beam, draft [m], mass [kg], displacement [m^3],
  block_coefficient, windage areas frontal_area and lateral_area [m^2, projected above the
  waterline], and ``extra`` (name -> number).
* ``identification`` (optional): provenance written by :mod:`usvid.identify`; ``data`` (list of
  source names), ``method``, ``std_errors`` (parameter name -> standard error [SI], >= 0, or
  null when not determined), ``covariance`` (``{"names": [...], "matrix": [[...]]}``: distinct
  parameters of the kind, a square, symmetric, positive semi-definite matrix of finite numbers,
  one row and column per name) and ``fit`` dictionaries, and any further keys (free-form
  provenance is the one place unknown keys are accepted). The uncertainty blocks are read by
  :class:`usvid.models.uncertainty.Uncertainty` (the one reader), which checks them when the
  file is loaded.

Model files are untrusted input: every field is validated (pydantic v2, strict types, no NaN or
infinity, unknown keys rejected) and a failure raises :class:`usvid.errors.ModelFileError` whose
one-line message names the file and the field, e.g.
``m.json: parameters.T must be > 0 (got -1.2)``.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
import typing
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, create_model, field_validator
from pydantic_core import PydanticCustomError

from usvid.errors import ModelFileError, UsvidError
from usvid.files import jsonable, load_json_text, read_input_text, write_atomic
from usvid.models import registry
from usvid.models.model import VesselModel
from usvid.models.servo import FirstOrderServo, IdealServo, SecondOrderServo
from usvid.models.thrust import THRUST_LAWS
from usvid.models.uncertainty import Uncertainty
from usvid.trial import VESSEL_FIELDS, Vessel

__all__ = [
    "MODEL_KINDS",
    "SERVO_KINDS",
    "load_model",
    "save_model",
    "model_from_dict",
    "model_to_dict",
    "validate_model_dict",
]

FORMAT_VERSION = 1
MODEL_KINDS = registry.names()
SERVO_KINDS = ("ideal", "first_order", "second_order")

_STRICT = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)

Num = float  # strict mode accepts int and float for a float field, rejects str and bool
Pos = Annotated[float, Field(gt=0)]
NonNeg = Annotated[float, Field(ge=0)]


# ---------------------------------------------------------------------------------------------
# schema
# ---------------------------------------------------------------------------------------------
class _Servo(BaseModel):
    model_config = _STRICT
    max_angle_deg: Annotated[float, Field(gt=0, le=180)] = 35.0
    max_rate_deg_s: Pos | None = None


#: Longest servo dead time accepted [s].
MAX_SERVO_DELAY_S = 3600.0


class IdealServoSpec(_Servo):
    kind: Literal["ideal"]


class FirstOrderServoSpec(_Servo):
    kind: Literal["first_order"]
    T: NonNeg


class SecondOrderServoSpec(_Servo):
    kind: Literal["second_order"]
    omega_n: Pos
    zeta: NonNeg
    gain: Pos = 1.0
    # a dead time beyond an hour is no servo (and would need an hour of samples per run)
    delay: Annotated[float, Field(ge=0, le=MAX_SERVO_DELAY_S, allow_inf_nan=False)] = 0.0


ServoSpec = Annotated[
    IdealServoSpec | FirstOrderServoSpec | SecondOrderServoSpec, Field(discriminator="kind")
]


class VesselSpec(BaseModel):
    model_config = _STRICT
    length: Pos | None = None
    speed: Pos | None = None
    beam: Pos | None = None
    draft: Pos | None = None
    mass: Pos | None = None
    displacement: Pos | None = None
    block_coefficient: Annotated[float, Field(gt=0, le=1)] | None = None
    frontal_area: Pos | None = None
    lateral_area: Pos | None = None
    extra: dict[str, float] = Field(default_factory=dict)


class CovarianceSpec(BaseModel):
    model_config = _STRICT
    names: list[str]
    matrix: list[list[float]]


class WindIdentificationSpec(BaseModel):
    """``identification.wind``: the wind the model was identified through
    (:class:`usvid.identify.wind.WindFit`): the wind-load model (null: none, fitted as calm
    water) and why, ``wind_scale`` [-] with its standard error and 95 % interval, ``held``
    (why it was held at 1, or null), the trials that logged the wind."""

    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=True)
    model: Literal["fujiwara1998", "blendermann1994"] | None = None
    reason: str = ""
    model_reason: str | None = None
    wind_scale: Annotated[float, Field(ge=0, allow_inf_nan=False)] = 1.0
    std_error: Annotated[float, Field(ge=0)] | None = 0.0
    ci95: list[float | None] = Field(default_factory=lambda: [1.0, 1.0], min_length=2,
                                     max_length=2)
    held: str | None = None
    trials: list[str] = Field(default_factory=list)


class IdentificationSpec(BaseModel):
    model_config = ConfigDict(extra="allow", strict=True, allow_inf_nan=True)
    data: list[str] = Field(default_factory=list)
    method: str = ""
    # a standard error is never negative (and was once used as its absolute value)
    std_errors: dict[str, Annotated[float, Field(ge=0, allow_inf_nan=False)] | None] = Field(
        default_factory=dict)
    covariance: CovarianceSpec | None = None
    fit: dict[str, Any] = Field(default_factory=dict)
    wind: WindIdentificationSpec | None = None


class ModelFileSpec(BaseModel):
    model_config = _STRICT
    usvid_model: Literal[1]
    kind: str
    parameters: dict[str, Any]
    servo: ServoSpec = Field(default_factory=lambda: IdealServoSpec(kind="ideal"))
    vessel: VesselSpec = Field(default_factory=VesselSpec)
    identification: IdentificationSpec | None = None

    @field_validator("usvid_model", mode="before")
    @classmethod
    def _integer_version(cls, v: Any) -> Any:
        # Literal[1] alone accepts true and 1.0 (both == 1); the version is the integer 1
        if isinstance(v, bool) or not isinstance(v, int):
            raise PydanticCustomError("literal_error", "must be 1", {"expected": "1"})
        return v


    @field_validator("kind")
    @classmethod
    def _known_kind(cls, v: str) -> str:
        if v not in registry.names():
            raise PydanticCustomError("literal_error", "must be {expected}",
                                      {"expected": "one of " + ", ".join(registry.names())})
        return v


# ---------------------------------------------------------------------------------------------
# error messages
# ---------------------------------------------------------------------------------------------
#: pydantic's location tags for the members of a union type (not field names)
_UNION_TAGS = {"float", "int", "str", "bool", "list[float]", "dict[str,any]", "dict[any,any]"}


def _loc(loc: tuple[Any, ...], prefix: str = "") -> str:
    parts = [prefix] if prefix else []
    for i, p in enumerate(loc):
        # drop the discriminator tag pydantic inserts for a tagged union (servo.second_order.x)
        if i > 0 and loc[i - 1] == "servo" and p in SERVO_KINDS:
            continue
        # and the member tag of a plain union (parameters.thrust.float, ...dict[str,any])
        if i > 0 and isinstance(p, str) and p in _UNION_TAGS:
            continue
        if isinstance(p, int):
            parts[-1:] = [f"{parts[-1]}[{p}]"] if parts else [f"[{p}]"]
        else:
            parts.append(str(p))
    return ".".join(parts) or "(top level)"


def _show(v: Any) -> str:
    if isinstance(v, float) and math.isnan(v):
        return "nan"
    text = json.dumps(v) if isinstance(v, (str, bool)) or v is None else repr(v)
    return text if len(text) <= 60 else text[:57] + "..."


#: pydantic error type -> (comparison, ctx key) of a violated bound
_BOUND_ERRORS = {"greater_than": (">", "gt"), "greater_than_equal": (">=", "ge"),
                 "less_than_equal": ("<=", "le")}
#: pydantic error type -> what the value must be
_TYPE_ERRORS = {"finite_number": "a finite number", "float_type": "a number",
                "int_type": "a number", "float_parsing": "a number", "int_from_float": "a number",
                "dict_type": "an object", "model_type": "an object", "list_type": "a list",
                "model_attributes_type": "an object", "bool_type": "true or false",
                "string_type": "a string"}


def _message(err: dict[str, Any], prefix: str = "") -> str:
    where = _loc(tuple(err.get("loc", ())), prefix)
    typ = err.get("type", "")
    ctx = err.get("ctx", {}) or {}
    got = err.get("input")
    if typ == "missing":
        return f"{where} is missing"
    if typ == "extra_forbidden":
        return f"unknown key {where}"
    if typ in _BOUND_ERRORS:
        op, key = _BOUND_ERRORS[typ]
        return f"{where} must be {op} {ctx.get(key):g} (got {_show(got)})"
    if typ in _TYPE_ERRORS:
        return f"{where} must be {_TYPE_ERRORS[typ]} (got {_show(got)})"
    if typ == "literal_error":
        return f"{where} must be {ctx.get('expected')} (got {_show(got)})"
    if typ == "union_tag_invalid":
        return f"{where}.kind must be one of {', '.join(SERVO_KINDS)} (got {_show(ctx.get('tag'))})"
    if typ == "union_tag_not_found":
        return f"{where}.kind is missing (one of {', '.join(SERVO_KINDS)})"
    return f"{where}: {err.get('msg', 'invalid')} (got {_show(got)})"


def _raise(exc: ValidationError, source: str, prefix: str = "") -> typing.NoReturn:
    errs = exc.errors()
    msg = _message(errs[0], prefix)
    more = f" (and {len(errs) - 1} more problem{'s' if len(errs) > 2 else ''})" if len(errs) > 1 \
        else ""
    raise ModelFileError(f"{source}: {msg}{more}") from None


# ---------------------------------------------------------------------------------------------
# 3-DOF and catamaran parameters: derived from the dataclasses of usvid.models
# ---------------------------------------------------------------------------------------------
def _field_type(f: dataclasses.Field) -> Any:
    """The JSON type of a dataclass field: from a kind's parameter declaration (a number, or a
    number / nested object for a sub-model), else read from its (string) annotation."""
    meta = f.metadata.get("usvid")
    if meta is not None:
        if meta.get("submodel"):
            return float | dict[str, Any] | None
        return float | None if meta.get("default") is None else float
    text = f.type if isinstance(f.type, str) else getattr(f.type, "__name__", repr(f.type))
    text = text.replace("typing.", "")
    optional = "None" in text or f.default is None
    if "tuple" in text or "list" in text:
        typ: Any = list[float]
    elif "Literal" in text or text == "str":
        typ = str
    elif text == "bool":
        typ = bool
    elif set(text.replace(" ", "").split("|")) <= {"float", "int", "ArrayLike", "None"}:
        typ = float
    else:  # a number or a nested thrust model object
        typ = float | dict[str, Any]
        optional = True
    return typ | None if optional else typ


def _nested_classes() -> dict[str, type]:
    """Thrust laws allowed as a nested ``{"kind": ..., ...}`` object."""
    return dict(THRUST_LAWS)


def _snake(name: str) -> str:
    out = []
    for i, c in enumerate(name):
        if c.isupper() and i > 0 and not name[i - 1].isupper():
            out.append("_")
        out.append(c.lower())
    return "".join(out)


@functools.cache
def _dataclass_params_model(cls: type, name: str) -> type[BaseModel]:
    """A strict pydantic model with one field per dataclass init field (numbers, strings,
    booleans, lists of numbers, or nested ``{"kind": ...}`` objects); built once per class."""
    fields: dict[str, Any] = {}
    for f in dataclasses.fields(cls):
        if not f.init or f.name.startswith("_"):
            continue
        typ = _field_type(f)
        if f.default is not dataclasses.MISSING:
            default = f.default
            if isinstance(default, tuple):
                default = list(default)
            if not isinstance(default, (int, float, str, list, type(None))):
                default = None
            fields[f.name] = (typ | None, default)
        elif f.default_factory is not dataclasses.MISSING:  # type: ignore[misc]
            fields[f.name] = (typ | None, None)
        else:
            fields[f.name] = (typ, ...)
    return create_model(name, __config__=_STRICT, **fields)


def _validated_kwargs(spec: type[BaseModel], body: dict[str, Any], where: str, source: str, *,
                      lists_as_tuples: bool = False) -> dict[str, Any]:
    """Validate ``body`` against ``spec`` and return the constructor keyword arguments: the
    fields given (or with a non-None default), nested ``{"kind": ...}`` objects built (lists made
    tuples when ``lists_as_tuples``). A bad field raises :class:`ModelFileError` at ``where``."""
    try:
        ok = spec.model_validate(body)
    except ValidationError as exc:
        _raise(exc, source, where)
    kwargs: dict[str, Any] = {}
    for k in spec.model_fields:
        v = getattr(ok, k)
        if v is None and k not in body:
            continue
        if lists_as_tuples and isinstance(v, list):
            kwargs[k] = tuple(v)
        else:
            kwargs[k] = _build_nested(v, f"{where}.{k}", source)
    return kwargs


def _build_nested(obj: Any, where: str, source: str) -> Any:
    """Turn a nested ``{"kind": "propeller", ...}`` object into its thrust dataclass."""
    if not isinstance(obj, dict):
        return obj
    classes = _nested_classes()
    kind = obj.get("kind")
    if not isinstance(kind, str) or kind not in classes:
        raise ModelFileError(f"{source}: {where}.kind must be one of "
                             f"{', '.join(sorted(classes))} (got {_show(kind)})")
    cls = classes[kind]
    spec = _dataclass_params_model(cls, f"{cls.__name__}Spec")
    body = {k: v for k, v in obj.items() if k != "kind"}
    kwargs = _validated_kwargs(spec, body, where, source, lists_as_tuples=True)
    try:
        return cls(**kwargs)
    except UsvidError as exc:
        head, _, rest = str(exc).partition(".")
        text = f"{where}.{rest}" if rest and " " not in head else f"{where}: {exc}"
        raise ModelFileError(f"{source}: {text}") from None
    except (TypeError, ValueError) as exc:
        raise ModelFileError(f"{source}: {where}: {exc}") from None


def _thrust_to_dict(obj: Any) -> Any:
    """A nested thrust dataclass as ``{"kind": <snake_case class name>, <fields>}``."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        out: dict[str, Any] = {"kind": _snake(type(obj).__name__)}
        for f in dataclasses.fields(obj):
            if f.init:
                out[f.name] = _jsonify(getattr(obj, f.name))
        return out
    return _jsonify(obj)


def _jsonify(v: Any) -> Any:
    if dataclasses.is_dataclass(v) and not isinstance(v, type):
        return _thrust_to_dict(v)
    if isinstance(v, np.ndarray):
        if v.ndim == 0:
            return float(v)
        raise ModelFileError("a batch of models (array parameters) cannot be written to one "
                             "model file; write one file per parameter set")
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, (list, tuple)):
        return [_jsonify(x) for x in v]
    if isinstance(v, dict):
        return {k: _jsonify(x) for k, x in v.items()}
    return v


# ---------------------------------------------------------------------------------------------
# public API
# ---------------------------------------------------------------------------------------------
def validate_model_dict(d: Any, source: str = "model") -> ModelFileSpec:
    """Validate the structure of a model-file dict; returns the parsed schema object.

    Raises :class:`ModelFileError` naming ``source`` and the first bad field.
    """
    if not isinstance(d, dict):
        raise ModelFileError(f"{source}: a model file must hold a JSON object "
                             f"(got {type(d).__name__})")
    try:
        return ModelFileSpec.model_validate(d)
    except ValidationError as exc:
        _raise(exc, source)


def _make_servo(spec: Any, source: str) -> Any:
    common = {"max_angle": math.radians(spec.max_angle_deg),
              "max_rate": math.inf if spec.max_rate_deg_s is None
              else math.radians(spec.max_rate_deg_s)}
    try:
        if spec.kind == "ideal":
            return IdealServo(**common)
        if spec.kind == "first_order":
            return FirstOrderServo(T=spec.T, **common)
        return SecondOrderServo(omega_n=spec.omega_n, zeta=spec.zeta, gain=spec.gain,
                                delay=spec.delay, **common)
    except UsvidError as exc:
        raise ModelFileError(f"{source}: {exc}") from None


def _make_dynamics(kind: str, params: dict[str, Any], source: str) -> Any:
    cls = registry.get(kind).dynamics
    spec = _dataclass_params_model(cls, f"{cls.__name__}Params")
    kwargs = _validated_kwargs(spec, params, "parameters", source)
    try:
        return cls(**kwargs)
    except UsvidError as exc:
        text = str(exc)
        if not text.startswith("parameters."):
            text = f"parameters: {text}"
        raise ModelFileError(f"{source}: {text}") from None
    except (TypeError, ValueError) as exc:
        raise ModelFileError(f"{source}: parameters: {exc}") from None


def model_from_dict(d: Any, source: str = "model") -> Any:
    """Build a :class:`usvid.models.model.VesselModel` from a model-file dict.

    ``source`` (usually the file name) prefixes every error message.
    """
    spec = validate_model_dict(d, source)
    dynamics = _make_dynamics(spec.kind, spec.parameters, source)
    servo = _make_servo(spec.servo, source)
    v = spec.vessel
    vessel = Vessel(**{k: getattr(v, k) for k in VESSEL_FIELDS}, extra=dict(v.extra))
    ident = spec.identification.model_dump() if spec.identification is not None else None
    for key in ("covariance", "wind"):  # optional blocks: absent, not null
        if ident is not None and ident.get(key) is None:
            ident.pop(key, None)
    model = VesselModel(dynamics, servo=servo, vessel=vessel, identification=ident)
    if ident:
        try:  # the uncertainty blocks as their one reader reads them (names, shape, symmetry)
            Uncertainty.from_model(model, source=source)
        except UsvidError as exc:
            raise ModelFileError(str(exc)) from None
    return model


def _servo_to_dict(servo: Any) -> dict[str, Any]:
    kind = getattr(servo, "kind", "ideal")
    out: dict[str, Any] = {"kind": kind}
    if kind == "first_order":
        out["T"] = float(servo.T)
    elif kind == "second_order":
        out.update(omega_n=float(servo.omega_n), zeta=float(servo.zeta), gain=float(servo.gain),
                   delay=float(servo.delay))
    # degrees rounded to 12 significant digits so that 30 -> rad -> deg writes 30, not 29.99...
    out["max_angle_deg"] = float(f"{math.degrees(float(servo.max_angle)):.12g}")
    rate = float(servo.max_rate)
    out["max_rate_deg_s"] = None if math.isinf(rate) else float(f"{math.degrees(rate):.12g}")
    return out


def model_to_dict(model: Any) -> dict[str, Any]:
    """The model-file dict (schema of ``ARCHITECTURE.md``) of a ``VesselModel``.

    Parameters are written in SI units; the servo limits in degrees (``max_angle_deg``,
    ``max_rate_deg_s``, null when unlimited). Round-trips through :func:`model_from_dict`.
    """
    dyn = model.dynamics
    kind = model.kind
    params: dict[str, Any] = {}
    for f in dataclasses.fields(dyn):
        if f.init:
            params[f.name] = _jsonify(getattr(dyn, f.name))
    vessel = model.vessel if model.vessel is not None else Vessel()
    vd: dict[str, Any] = {}
    for k in VESSEL_FIELDS:
        val = getattr(vessel, k)
        if val is not None:
            vd[k] = float(val)
    if vessel.extra:
        vd["extra"] = {k: float(x) for k, x in vessel.extra.items()}
    out: dict[str, Any] = {
        "usvid_model": FORMAT_VERSION,
        "kind": kind,
        "parameters": params,
        "servo": _servo_to_dict(model.servo),
        "vessel": vd,
    }
    if getattr(model, "identification", None):
        ident = model.identification
        if hasattr(ident, "to_dict"):
            ident = ident.to_dict()
        out["identification"] = jsonable(_jsonify(dict(ident)))  # NaN -> null
    return out


#: Largest model file accepted [characters] (identification metadata included; ~10 kB usual).
MAX_MODEL_CHARS = 50_000_000


def load_model(path: str | Path) -> Any:
    """Read and validate a model file; returns a :class:`usvid.models.model.VesselModel`.

    Raises :class:`ModelFileError` (file missing, not JSON, or a bad field; the message names
    the file and the field).
    """
    path = Path(path)
    source = path.name
    # a regular file of at most MAX_MODEL_CHARS bytes, UTF-8 (a FIFO or /dev/zero is refused)
    text = read_input_text(path, "model file", MAX_MODEL_CHARS, error=ModelFileError)
    try:
        # bounded nesting and integer size (usvid.files); NaN / Infinity literals are not JSON:
        # report them as a bad value of their field below
        d = load_json_text(text, source,
                           parse_constant=lambda c: float(c.replace("Infinity", "inf")))
    except UsvidError as exc:
        raise ModelFileError(str(exc)) from None
    return model_from_dict(d, source=source)


def save_model(model: Any, path: str | Path, *, inputs: Any = ()) -> Path:
    """Write ``model`` (a ``VesselModel``) as a model file, atomically. Returns the path.
    The one writer of model files (the CLI and the estimator's ``to_dict`` use it).
    ``inputs``: paths the model file must not overwrite (:func:`usvid.files.check_outputs`)."""
    d = model_to_dict(model)
    text = json.dumps(d, indent=2, allow_nan=False) + "\n"
    return write_atomic(path, text, inputs=inputs)
