"""The registry of model kinds: every module of :mod:`usvid.models.kinds` with a ``KIND``.

The one list of kinds: the modules (or packages) of :mod:`usvid.models.kinds` not named with a
leading ``_``, each defining ``KIND`` of its own name. ``get("norrbin")`` returns the
:class:`usvid.models.kind.ModelKind`; ``names()`` the kinds in a stable order (the CLI's
``--model`` choices; without importing them); ``readme_table()`` the README's kind table.
"""

from __future__ import annotations

import hashlib
import importlib
import inspect
import pkgutil
from functools import cache
from pathlib import Path
from typing import Any

from usvid.errors import UsvidError
from usvid.models import kinds as _kinds_pkg
from usvid.models.kind import Dynamics, ModelKind

#: Kinds listed first, in this order (others follow alphabetically).
_ORDER = ("nomoto1", "nomoto2", "norrbin", "threedof", "catamaran", "mmg")


def _models_digest() -> bytes:
    """Hash of every module of :mod:`usvid.models` (a kind's rhs inlines their numba functions,
    e.g. the thrust laws): part of each kind's ``source_hash``, so that a compiled core cached on
    disk is never reused after one of them changed."""
    root = Path(_kinds_pkg.__file__).resolve().parent.parent
    h = hashlib.sha256()
    for f in sorted(root.rglob("*.py")):
        h.update(f.read_bytes())
    return h.digest()


def names() -> tuple[str, ...]:
    """Kind names in display order: the kind modules (and packages) of
    :mod:`usvid.models.kinds`, by name, without importing them (the CLI's help lists them
    cheaply); :data:`_ORDER` first, then alphabetically. A module's kind has its module's name
    (checked by :func:`kinds`)."""
    found = [info.name for info in pkgutil.iter_modules(_kinds_pkg.__path__)
             if not info.name.startswith("_")]
    return tuple([k for k in _ORDER if k in found] + sorted(set(found) - set(_ORDER)))


@cache
def kinds() -> dict[str, ModelKind]:
    """All registered kinds by name (imported once), in the order of :func:`names`."""
    found: dict[str, ModelKind] = {}
    models = _models_digest()
    for name in names():
        module = importlib.import_module(f"{_kinds_pkg.__name__}.{name}")
        kind = getattr(module, "KIND", None)
        if not isinstance(kind, ModelKind):  # never skipped silently (a half-imported module
            # in an import cycle has no KIND yet; helpers are private modules, "_name.py")
            raise UsvidError(f"model kind module {module.__name__} defines no KIND "
                             "(a ModelKind); private helpers are named with a leading '_'")
        if kind.name != name:
            raise UsvidError(f"model kind module {module.__name__} defines the kind "
                             f"{kind.name!r}: a kind's module is named for it")
        digest = hashlib.sha256(inspect.getsource(module).encode() + models).hexdigest()[:12]
        object.__setattr__(kind, "source_hash", digest)
        found[kind.name] = kind
    return found


def get(name: str) -> ModelKind:
    """The kind called ``name``; :class:`UsvidError` listing the kinds otherwise."""
    ks = kinds()
    if name not in ks:
        raise UsvidError(f"unknown model kind {name!r} (one of {', '.join(ks)})")
    return ks[name]


def kind_of(dynamics: Any) -> ModelKind:
    """The kind of a parameter-set object (:class:`usvid.models.kind.Dynamics`)."""
    if not isinstance(dynamics, Dynamics):
        raise UsvidError(f"not a model parameter set: {type(dynamics).__name__} (one of "
                         f"{', '.join(k.dynamics.__name__ for k in kinds().values())})")
    return get(dynamics.kind)


def readme_table() -> str:
    """The Markdown table of kinds for the README (generated; a test keeps the README equal)."""
    lines = ["| kind | equations | parameters (SI) |", "|---|---|---|"]
    lines += [k.table_row() for k in kinds().values()]
    return "\n".join(lines)
