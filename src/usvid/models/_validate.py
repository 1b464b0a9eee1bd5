"""Early validation of parameter dataclasses: name the culprit, say what was expected."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from usvid.errors import UsvidError


def check_params(owner: str, values: dict[str, Any], *, positive: tuple[str, ...] = (),
                 nonnegative: tuple[str, ...] = ()) -> None:
    """Raise :class:`UsvidError` when a parameter is not finite, not positive or negative.

    Parameters may be scalars or arrays (a batch of parameter sets); every element is checked.
    The message names the parameter as ``<owner>.<name>`` and gives the offending value.
    """
    for name, value in values.items():
        arr = np.asarray(value, dtype=float)
        if not np.all(np.isfinite(arr)):
            raise UsvidError(f"{owner}.{name} must be finite (got {_show(arr)})")
        if name in positive and not np.all(arr > 0):
            raise UsvidError(f"{owner}.{name} must be > 0 (got {_show(arr)})")
        if name in nonnegative and not np.all(arr >= 0):
            raise UsvidError(f"{owner}.{name} must be >= 0 (got {_show(arr)})")


def checked(owner: str, *, positive: tuple[str, ...] = (), nonnegative: tuple[str, ...] = (),
            **values: Any) -> tuple[np.ndarray, ...]:
    """The ``values`` as float arrays, in their order, after :func:`check_params`."""
    check_params(owner, values, positive=positive, nonnegative=nonnegative)
    return tuple(np.asarray(v, dtype=float) for v in values.values())


def _show(arr: np.ndarray) -> str:
    if arr.ndim == 0:
        v = float(arr)
        return "nan" if math.isnan(v) else repr(v)
    bad = arr[~np.isfinite(arr)] if not np.all(np.isfinite(arr)) else arr.ravel()[:3]
    return np.array2string(np.asarray(bad)[:3])
