"""The MMG model's physics API under its earlier import path: every name is looked up in
:mod:`usvid.models.kinds.mmg.physics` (the kind ``mmg`` is one package,
:mod:`usvid.models.kinds.mmg`; nothing is defined here)."""

from __future__ import annotations

from typing import Any

from usvid.models.kinds.mmg import physics as _physics


def __getattr__(name: str) -> Any:
    return getattr(_physics, name)


def __dir__() -> list[str]:
    return sorted(n for n in vars(_physics) if not n.startswith("__"))
