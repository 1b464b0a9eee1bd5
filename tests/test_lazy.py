"""The packages' names loaded on first use (:func:`usvid.lazy.lazy_names`)."""

from __future__ import annotations

import sys
import types

import pytest

from usvid.lazy import lazy_names


def test_a_name_is_imported_on_first_use_and_kept(monkeypatch) -> None:
    pkg = types.ModuleType("fakepkg")
    pkg.__path__ = []  # a package
    monkeypatch.setitem(sys.modules, "fakepkg", pkg)
    # a module nothing else here loads shows the laziness (removed from sys.modules first)
    monkeypatch.delitem(sys.modules, "colorsys", raising=False)
    pkg.__getattr__, pkg.__dir__ = lazy_names("fakepkg", {"rgb_to_hsv": "colorsys"})
    assert "colorsys" not in sys.modules
    f = pkg.rgb_to_hsv
    assert "colorsys" in sys.modules and f is sys.modules["colorsys"].rgb_to_hsv
    assert pkg.__dict__["rgb_to_hsv"] is f  # kept: later uses are plain lookups
    assert "rgb_to_hsv" in dir(pkg)
    with pytest.raises(AttributeError, match="module 'fakepkg' has no attribute 'nope'"):
        _ = pkg.nope


def test_a_submodule_by_its_name() -> None:
    import usvid.manoeuvres as m

    assert m.detect is sys.modules["usvid.manoeuvres.detect"]
    assert {"detect", "find_manoeuvres", "ZigZag"} <= set(dir(m))
    with pytest.raises(AttributeError, match="module 'usvid.manoeuvres' has no attribute 'x'"):
        _ = m.x
