"""Compilation of the integration core: the chunk driver once, each kind's code on first use.

The core's numba functions are *templates* (:mod:`usvid.sim.chunk`, :mod:`usvid.sim.lane`,
:mod:`usvid.sim.vector`): re-created with the globals of a specialisation and compiled under
a name that carries what they were specialised for, so that numba's on-disk cache of one
specialisation is never taken for another's:

* the chunk driver (:func:`driver`), the same for every kind, named for the core's sources
  (:func:`core_digest`);
* per kind (:func:`kernel`): its per-lane step (a C callback: the kind's right-hand side out of
  line once, RK4, the sub-steps at events), named for the kind, a hash of its sources and the
  core's; with an environment (force or current series, :func:`lane_step`) a second one;
* per kind and variant (:func:`vector_step`): its vector step (a C callback, the right-hand
  side inlined four times; a large kind's generic step calls it out of line), compiled only
  for the variants a batch needs.

The joint-state and parameter helpers of a kind are generated from its state names
(:mod:`usvid.sim.layout`) and compiled into these functions (LLVM inlines them).
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import hashlib
import importlib
import types
from dataclasses import dataclass
from typing import Any

import llvmlite.binding as _llvm
import numba
import numpy as np
from numba.core.compiler_lock import global_compiler_lock

import usvid.jitcache  # noqa: F401 - numba's cache written best effort
from usvid.models.kind import ModelKind
from usvid.sim import chunk as _chunk_mod
from usvid.sim import lane as _lane_mod
from usvid.sim import layout as _layout
from usvid.sim import scalar as _scalar
from usvid.sim import vector as _vector_mod
from usvid.sim.scalar import _FM

#: Kinds with more parameters than this keep one out-of-line copy of their right-hand side in
#: their generic vector step (lanes of mixed switch values: every branch of the right-hand side
#: would be inlined four times per RK4 step, minutes of compilation for an MMG model) and one
#: generic variant; the vector step of a switch value (only its branch, a constant) inlines it
#: whatever the kind's size, like a small kind's.
INLINE_MAX_PARAMS = 40

#: The per-lane path's templates (:mod:`usvid.sim.lane`); the C callback :func:`lane._lstep`.
LANE_TEMPLATES = ("_inputs", "_heldload", "_holdset", "_holdget", "_deriv", "_rk4",
                  "_substeps")
#: The vector path's templates (:mod:`usvid.sim.vector`); the C callback :func:`vector._vstep`.
VECTOR_TEMPLATES = ("_dnow", "_steer", "_heldload", "_holdset", "_holdget", "_hbase", "_vheld",
                    "_vderiv", "_vrk4")
#: The generated joint-state helpers of a vector-step variant (:func:`layout.joint_helpers`).
VARIANT_HELPERS = ("_vaxpy", "_vrk4sum", "_vput")
#: Templates inlined by LLVM where they are called (tuples only: no reference counting; numba's
#: own inlining, inline="always", copies the IR at every call site, most of the compile time).
#: ``_deriv`` stays out of line in the per-lane step (integrating only the steps with an event
#: inside, or lanes the vector step does not take): a quarter of the compile work.
_FORCEINLINE = ("_rk4", "_heldload", "_holdset", "_holdget", "_hbase", "_vheld", "_inputs",
                "_substeps", "_dnow", "_steer", "_vderiv", "_vrk4", "_chval", "_finite_rows")

_MODULES = (_scalar, _layout, _lane_mod, _vector_mod, _chunk_mod)
#: The modules of the environment's numba functions the templates compile into themselves
#: (numba's cache of a function is keyed to its own file only: without these in the digest, an
#: edited load formula would leave the cached kernels with the old one).
_INLINED = tuple(importlib.import_module(f"usvid.models.environment.{m}")
                 for m in ("wind", "wind_loads", "waves"))


@functools.cache
def core_digest() -> str:
    """A hash of the core's sources (the modules whose code the templates compile)."""
    h = hashlib.sha256()
    for path in [m.__file__ for m in _MODULES + _INLINED] + [__file__]:
        with open(path, "rb") as f:
            h.update(f.read())
    return h.hexdigest()[:10]


def _globals() -> dict[str, Any]:
    """The templates' common globals: every name of the core's modules."""
    g: dict[str, Any] = {}
    for mod in _MODULES:
        g.update({k: v for k, v in vars(mod).items() if not k.startswith("__")})
    g["__builtins__"] = __builtins__
    return g


def _template(name: str) -> Any:
    for mod in (_chunk_mod, _lane_mod, _vector_mod):
        if name in vars(mod):
            return vars(mod)[name]
    raise KeyError(name)


def _specialise(g: dict[str, Any], name: str, qual: str, sig: Any = None, *,
                forceinline: bool | None = None, nogil: bool = False) -> Any:
    """Compile the template ``name`` with the globals ``g`` under the name ``qual`` into g
    (``sig``: as a C callback of that signature, compiled now); returns it."""
    template = _template(name)
    code = template.__code__.replace(co_name=qual, co_qualname=qual)
    fn = types.FunctionType(code, g, qual, template.__defaults__)
    fn.__qualname__ = qual
    fn.__module__ = template.__module__
    opts: dict[str, Any] = {"cache": True, "error_model": "numpy", "fastmath": _FM}
    if nogil:
        opts["nogil"] = True
    if forceinline if forceinline is not None else name in _FORCEINLINE:
        opts["forceinline"] = True
    g[name] = numba.cfunc(sig, **opts)(fn) if sig is not None else numba.njit(**opts)(fn)
    return g[name]


@contextlib.contextmanager
def _interleaved(n: int) -> Any:
    """Compile with LLVM's loop vectoriser interleaving ``n`` vectors (its option
    ``-force-vector-interleave``; 0, its default, lets its cost model choose) and restore the
    default after: an option of the process's LLVM, set under numba's compiler lock so that no
    other compilation sees it. The cost model interleaves only small loop bodies; a vector step
    is thousands of instructions, for which it keeps one vector (:class:`ModelKind`'s
    ``vector_interleave``). llvmlite ignores an option its LLVM does not have."""
    if n <= 1:
        yield
        return
    with global_compiler_lock:
        _llvm.set_option("usvid", f"-force-vector-interleave={n}")
        try:
            yield
        finally:
            _llvm.set_option("usvid", "-force-vector-interleave=0")


def _helper(fn: Any) -> Any:
    """Compile a generated joint-state helper (inlined by LLVM; not cached on disk: it is
    compiled only into the cached functions, which carry it)."""
    return numba.njit(error_model="numpy", fastmath=_FM, forceinline=True)(fn)


_DRIVER: list[Any] = []


def driver() -> Any:
    """The chunk driver (:func:`usvid.sim.chunk._chunk`), specialised once for every kind."""
    if not _DRIVER:
        g = _globals()
        key = f"core_{core_digest()}"
        for name in _chunk_mod.TEMPLATES:
            _specialise(g, name, f"{name}__{key}", nogil=name == "_chunk")
        _DRIVER.append(g["_chunk"])
    return _DRIVER[0]


@dataclass(frozen=True)
class KindCode:
    """A kind's compiled code: its ``layout``, ``kinfo`` (int64 array, :data:`layout.KINFO`),
    the address of its per-lane step ``lstep``, its switch row and values (``swr``: -1 none,
    ``swv`` the values with vector steps of their own; the last vector step, index
    ``len(swv)``, is the generic one), the specialisation's ``key`` and globals ``g``."""

    layout: _layout.Layout
    kinfo: np.ndarray
    lstep: int
    swr: int
    swv: tuple[float, ...]
    key: str
    g: dict[str, Any]
    env: dict[str, Any] = dataclasses.field(default_factory=dict)

    def chunk_switch(self, P: np.ndarray, lo: int, hi: int) -> int:
        """The vector step index of the lanes lo..hi-1 of the (lanes x rows) parameters P: the
        index of their common value of the switch row in ``swv``, else the generic one."""
        if self.swr < 0:
            return len(self.swv)
        seg = P[lo:hi, self.swr]
        if np.any(seg != seg[0]) or float(seg[0]) not in self.swv:
            return len(self.swv)
        return self.swv.index(float(seg[0]))


_KINDS: dict[str, KindCode] = {}
_VSTEPS: dict[tuple[Any, ...], Any] = {}  # the compiled vector steps, by kind key and variant


def kernel_key(kind: ModelKind) -> str:
    """The name of a kind's specialisation: the kind, a hash of its sources (its module and
    :mod:`usvid.models`, :mod:`usvid.models.registry`) and the core's (:func:`core_digest`)."""
    return f"{kind.name}_{kind.source_hash or 'x'}_{core_digest()}"


def kernel(kind: ModelKind) -> KindCode:
    """The code of ``kind`` (its per-lane step compiled at first call, cached on disk)."""
    key = kernel_key(kind)
    if key in _KINDS:
        return _KINDS[key]
    lay = _layout.Layout(kind.n_states, kind.n_params)
    js = _layout.JS
    phi, p = kind.state_row("phi"), kind.state_row("p")
    pos = {"zu": js + kind.body[0] if kind.body[0] >= 0 else -1,
           "zv": js + kind.body[1] if kind.body[1] >= 0 else -1,
           "zr": js + kind.body[2], "zphi": js + phi if phi >= 0 else -1,
           "zp": js + p if p >= 0 else -1}
    g = _globals()
    g.update(lay.constants())
    g.update(rhs=kind.rhs, TRIG=bool(kind.uses_trig), ZR=pos["zr"], ENV=False, WIND=False,
             ZU=pos["zu"], ZV=pos["zv"], SPEEDROW=kind.speed_row)
    for name, fn in _layout.joint_helpers(lay, g).items():
        g[name] = _helper(fn)
    g["_ptup"] = numba.njit(forceinline=True)(_layout.param_tuple(lay, g))
    g["_etup"] = numba.njit(forceinline=True)(_layout.env_tuple(lay, g, read=False))
    lstep = _lane_step(dict(g), key, "")
    values = tuple(float(v) for v in kind.switch_values) if kind.switch_row >= 0 else ()
    if len(values) > 3:
        raise ValueError(f"kind {kind.name}: at most 3 switch values")
    code = KindCode(layout=lay, kinfo=np.array(lay.kinfo(
        speed_row=kind.speed_row, trig=bool(kind.uses_trig), **pos), dtype=np.int64),
        lstep=lstep.address, swr=kind.switch_row if values else -1, swv=values, key=key, g=g)
    _KINDS[key] = code
    return code


def _lane_step(g: dict[str, Any], key: str, tag: str) -> Any:
    """The per-lane step (:func:`usvid.sim.lane._lstep`) of the globals ``g``."""
    for name in LANE_TEMPLATES:
        _specialise(g, name, f"{name}{tag}__{key}",
                    forceinline=False if name == "_deriv" else None)
    return _specialise(g, "_lstep", f"_lstep{tag}__{key}", _lane_mod.LSIG)


def lane_step(kind: ModelKind, env: bool) -> int:
    """Address of the per-lane step of ``kind``: calm water, or (``env``) with the environment
    series (external force, current); the latter compiled at first use."""
    code = kernel(kind)
    if not env:
        return code.lstep
    if "lstep" not in code.env:
        code.env["lstep"] = _lane_step(dict(code.g, ENV=True), code.key, "e").address
    return code.env["lstep"]


def _wind_globals(code: KindCode) -> dict[str, Any]:
    """The globals of ``code`` with the state-dependent environment (``ENV``, ``WIND``): the
    layout constants of the chunk array with the environment block
    (:data:`usvid.sim.layout.NENV` rows) after the kind's parameters, and ``_etup`` reading
    it (made once per kind)."""
    if "g" not in code.env:
        lay = code.layout
        wide = _layout.Layout(lay.ns, lay.npk + _layout.NENV)
        g = dict(code.g, ENV=True, WIND=True)
        g.update(wide.constants())
        g["_etup"] = numba.njit(forceinline=True)(_layout.env_tuple(lay, g, read=True))
        k = code.kinfo.copy()
        for i, v in ((_layout.KNPK, wide.npk), (_layout.KVB, wide.vb), (_layout.KVN, wide.vn),
                     (_layout.KROWS, wide.rows)):
            k[i] = v
        code.env["g"] = g
        code.env["wkinfo"] = k
    return code.env["g"]


def wind_step(kind: ModelKind) -> tuple[int, np.ndarray]:
    """(address, kinfo) of the per-lane step of ``kind`` with the state-dependent environment
    (wind loads from the apparent wind, mean wave drift; :func:`usvid.sim.lane._envload`) and
    the environment series, compiled at first use. Its chunk array has the environment block
    (:data:`usvid.sim.layout.NENV` rows) after the kind's parameters: the batch's parameters
    carry it as their last rows, and its ``kinfo`` says so (the driver loads all of them)."""
    code = kernel(kind)
    if "wstep" not in code.env:
        code.env["wstep"] = _lane_step(dict(_wind_globals(code)), code.key, "w").address
    return code.env["wstep"], code.env["wkinfo"]  # type: ignore[return-value]


def vector_step(kind: ModelKind, swi: int, sk: int, nod: bool, xy: bool, *,
                generic: bool = False, wind: bool = False, wcode: int = -1,
                narrow: bool = False, shared: bool = False, steady: bool = False,
                force: bool = True) -> int:
    """Address of the vector step (:func:`usvid.sim.vector._vstep`, a C callback) of ``kind``
    for the switch value ``swi`` (index into the kind's switch values; the last: generic), the
    servo kind ``sk``, without disturbance and input series (``nod``), with x and y (``xy``);
    compiled at first use (cached on disk), only the variants a batch needs.

    One variant per combination keeps the vector code free of the others' branches: the
    servo's blend of the three kinds, the disturbance filter, the first-order-hold series and,
    when neither x nor y is recorded, the position and the heading's rotation (the quiet lanes'
    x and y then stay as they were: nothing reads them). The switch row of the parameters is a
    literal in the variant of a switch value (e.g. one thrust law in the code, not all). The
    generic step of a kind whose right-hand side is then not inlined (more parameters than
    :data:`INLINE_MAX_PARAMS`, no switch literal: its lane loop is not vectorised, the variants
    would gain little), and every kind with ``generic``, has one variant per switch value: any
    servo kind (``sk`` -1: the per-lane path's blend), disturbance, series, x and y.

    ``wind``: the variant of a batch with the state-dependent environment (wind loads, wave
    drift; the chunk array of :func:`wind_step`, its ``kinfo``), the loads computed by the
    per-lane step's own function (:func:`usvid.sim.lane._envload`) at the steps of the
    multirate hold and extrapolated between (:func:`usvid.sim.lane._holdget`), with the
    series and x, y (the heading's rotation); without it the variants compile as if the
    environment code did not exist (``WIND`` a compile-time False). ``wcode``: the wind-load
    model's code (:mod:`usvid.models.environment.wind_loads`) common to the batch's lanes, a
    literal in the variant (only that model's code compiled); -1: read per lane. ``shared``:
    every lane has the same environment block (read once per step, from lane slot 0, before
    the lane loop). ``steady``: the batch's series are the environment's only and constant in
    time, or absent (the driver loads them once): the external force is added to the held
    loads once per step (:func:`usvid.sim.vector._vstep`), not interpolated at every RK4
    stage, and the series' end rows are not read (the same sums: the interpolation of a
    constant is that constant). Both only with ``wind``: fewer rows of the chunk array read
    per step and fewer values live in the RK4 loop (sampled in the 3-DOF zig-zag of
    ``benchmarks/bench_sim.py --wind``: its RK4 loop took 1.58x the calm variant's, a tenth
    of the step's samples stalled at one parameter load; with both, 1.13x).

    ``force``: with ``steady``, some lane has an external force series; without one its
    rows (zeros) are not read (their loads and adds: in the heading-only wind zig-zag of the
    benchmark 25.9 -> 22.9 ns a lane-step, the calm variant's 16.6, load average 5).

    ``narrow``: the variant for a chunk of at most :data:`usvid.sim.vector.VW` lanes (a single
    run, a few runs): its lane loop computes VW lane slots instead of :data:`CH` (a constant
    trip count either way, so that LLVM vectorises it), compiled only when such a chunk runs."""
    code = kernel(kind)
    lay = code.layout
    literal = code.swr >= 0 and swi < len(code.swv)  # the switch row a constant
    inline = lay.npk <= INLINE_MAX_PARAMS or literal
    if not inline or generic:
        sk, nod, xy = -1, False, True
    if not wind:
        wcode, shared, steady = -1, False, False
    if not steady:
        force = True
    vk = (code.key, swi, sk, bool(nod), bool(xy), bool(wind), int(wcode), bool(narrow),
          bool(shared), bool(steady), bool(force))
    if vk in _VSTEPS:
        return _VSTEPS[vk].address
    const = {code.swr: code.swv[swi]} if code.swr >= 0 and swi < len(code.swv) else {}
    gv = dict(_wind_globals(code) if wind else code.g, SK=sk, NOD=bool(nod), XY=bool(xy),
              NLANES=_vector_mod.VW if narrow else _layout.CH, SHARED=bool(shared),
              STEADY=bool(steady), FORCE=bool(force))
    if wind and wcode >= 0:
        gv["_etup"] = numba.njit(forceinline=True)(_layout.env_tuple(
            lay, gv, read=True, const={0: float(wcode)}))
    gv["_ptup"] = numba.njit(forceinline=True)(_layout.param_tuple(lay, gv, const))
    helpers = _layout.joint_helpers(lay, gv, xy=bool(xy), nod=bool(nod))
    for name in VARIANT_HELPERS:
        gv[name] = _helper(helpers[name])
    tag = (f"{swi}{'g' if sk < 0 else sk}{int(bool(nod))}{int(bool(xy))}"
           + (f"w{wcode if wcode >= 0 else 'g'}{'s' if shared else ''}{'c' if steady else ''}"
              f"{'' if force else 'f'}"
              if wind else "") + ("n" if narrow else ""))
    for name in VECTOR_TEMPLATES:
        _specialise(gv, name, f"{name}{tag}__{code.key}",
                    forceinline=False if (name == "_vderiv" and not inline) else None)
    # a narrow step's VW lane slots are one vector: nothing to interleave
    with _interleaved(1 if narrow or not inline else kind.vector_interleave):
        _VSTEPS[vk] = _specialise(gv, "_vstep", f"_vstep{tag}__{code.key}", _vector_mod.VSIG)
    return _VSTEPS[vk].address
