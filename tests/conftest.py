"""Shared test fixtures: paths to the real data in ../shared/data (never copied into the repo)."""

from __future__ import annotations

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO.parent / "shared" / "data"
HSVA_DIR = SHARED_DATA / "kvlcc2_hsva"
TWIN_DIR = SHARED_DATA / "usv_twin_thruster"


@pytest.fixture(scope="session")
def hsva_dir() -> Path:
    """Folder of the HSVA KVLCC2 zig-zags; the test is skipped when it is absent."""
    if not HSVA_DIR.is_dir():
        pytest.skip(f"real data not found at {HSVA_DIR} (../shared/data is not beside the repo)")
    return HSVA_DIR


@pytest.fixture(scope="session")
def twin_dir() -> Path:
    """Folder of the twin-thruster USV Excel logs; skipped when absent."""
    if not TWIN_DIR.is_dir():
        pytest.skip(f"real data not found at {TWIN_DIR} (../shared/data is not beside the repo)")
    return TWIN_DIR
