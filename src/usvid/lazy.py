"""Names of a package loaded with their modules on first use (PEP 562, "Module __getattr__ and
__dir__", Levkivskyi 2017): the one definition of the packages' lazy ``__getattr__`` and
``__dir__``, so that importing a package loads only the modules a caller uses (``import
usvid.sim`` needs neither the detection of manoeuvres nor pandas)."""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Iterable, Mapping
from typing import Any


def lazy_names(package: str, where: Mapping[str, str], submodules: Iterable[str] = ()
               ) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """(``__getattr__``, ``__dir__``) for the package named ``package`` (its ``__name__``): a
    name of ``where`` (name -> the absolute name of the module that defines it) is imported
    from that module on its first use and kept in the package's namespace (later uses are
    plain lookups); a name of ``submodules`` is the package's submodule of that name; any
    other name raises AttributeError as a module without ``__getattr__`` does."""
    namespace = sys.modules[package].__dict__
    subs = frozenset(submodules)

    def __getattr__(name: str) -> Any:
        module = where.get(name)
        if module is not None:
            value = getattr(importlib.import_module(module), name)
            namespace[name] = value
            return value
        if name in subs:
            return importlib.import_module(f"{package}.{name}")
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(where) | subs)

    return __getattr__, __dir__


__all__ = ["lazy_names"]
