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
        if isinstance(value, (int, float)) and math.isfinite(value) \
                and (name not in positive or value > 0) \
                and (name not in nonnegative or value >= 0):
            continue  # a number that passes: no array to build
        arr = np.asarray(value, dtype=float)
        if not np.all(np.isfinite(arr)):
            raise UsvidError(f"{owner}.{name} must be finite (got {_show(arr)})")
        if name in positive and not np.all(arr > 0):
            raise UsvidError(f"{owner}.{name} must be > 0 (got {_show(arr, ~(arr > 0))})")
        if name in nonnegative and not np.all(arr >= 0):
            raise UsvidError(f"{owner}.{name} must be >= 0 (got {_show(arr, ~(arr >= 0))})")


def checked(owner: str, *, positive: tuple[str, ...] = (), nonnegative: tuple[str, ...] = (),
            **values: Any) -> tuple[np.ndarray, ...]:
    """The ``values`` as float arrays, in their order, after :func:`check_params`."""
    check_params(owner, values, positive=positive, nonnegative=nonnegative)
    return tuple(np.asarray(v, dtype=float) for v in values.values())


def _show(arr: np.ndarray, bad: np.ndarray | None = None) -> str:
    """A value for an error message: a scalar as it is; of a batch (an array of lanes) the
    first offending lane (``bad``, default the non-finite ones) with its index."""
    if arr.ndim == 0:
        v = float(arr)
        return "nan" if math.isnan(v) else repr(v)
    flat = arr.ravel()
    mask = (~np.isfinite(flat)) if bad is None else np.asarray(bad, dtype=bool).ravel()
    if not mask.any():
        return np.array2string(flat[:3])
    i = int(np.argmax(mask))
    v = float(flat[i])
    return (f"{'nan' if math.isnan(v) else repr(v)} in lane {i} of {flat.size}"
            + (f", {int(mask.sum())} lanes out of range" if mask.sum() > 1 else ""))
