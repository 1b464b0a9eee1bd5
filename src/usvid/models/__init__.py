"""usvid.models: model kinds (parameter sets and their one right-hand side), servos, thrust
laws, hull regressions. No integration (see ``usvid.sim``), no files (see ``usvid.io``).

Kinds (:mod:`usvid.models.registry`, one module each in :mod:`usvid.models.kinds`): Nomoto1,
Nomoto2, Norrbin, ThreeDOF, Catamaran, MMG; servos (:mod:`.servo`); thrust laws (:mod:`.thrust`);
the complete model (:mod:`.model`): VesselModel.

The names below are imported on first use (importing :mod:`usvid.models.registry` alone does not
import the kinds: the CLI's help lists them cheaply).
"""

from __future__ import annotations

import importlib
from typing import Any

#: Public name -> (module, attribute; None: the module itself).
_LAZY: dict[str, tuple[str, str | None]] = {
    "Catamaran": ("usvid.models.kinds.catamaran", "Catamaran"),
    "Nomoto1": ("usvid.models.kinds.nomoto1", "Nomoto1"),
    "Nomoto2": ("usvid.models.kinds.nomoto2", "Nomoto2"),
    "Norrbin": ("usvid.models.kinds.norrbin", "Norrbin"),
    "MU2018_EQ37": ("usvid.models.kinds.threedof", "MU2018_EQ37"),
    "ThreeDOF": ("usvid.models.kinds.threedof", "ThreeDOF"),
    "VesselModel": ("usvid.models.model", "VesselModel"),
    "get_kind": ("usvid.models.registry", "get"),
    "kind_names": ("usvid.models.registry", "names"),
    "registry": ("usvid.models.registry", None),
    "FirstOrderServo": ("usvid.models.servo", "FirstOrderServo"),
    "IdealServo": ("usvid.models.servo", "IdealServo"),
    "SecondOrderServo": ("usvid.models.servo", "SecondOrderServo"),
    "mu2018_servo": ("usvid.models.servo", "mu2018_servo"),
}

__all__ = [*sorted(_LAZY), "mu2018_threedof"]


def __getattr__(name: str) -> Any:
    if name not in _LAZY:
        raise AttributeError(f"module 'usvid.models' has no attribute {name!r}")
    module, attr = _LAZY[name]
    mod = importlib.import_module(module)
    value = mod if attr is None else getattr(mod, attr)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))


def mu2018_threedof(x_l: float = 3.5, **kw: object) -> Any:
    """The Lanxin model of Mu et al. 2018, eq. 37 (x_l [m] is not printed; ~half the length)."""
    return __getattr__("ThreeDOF").from_regression(**__getattr__("MU2018_EQ37"), x_l=x_l, **kw)
