"""Shared test fixtures: paths to the real data in ../shared/data (never copied into the repo)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from usvid.models import registry

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO.parent / "shared" / "data"
HSVA_DIR = SHARED_DATA / "kvlcc2_hsva"
TWIN_DIR = SHARED_DATA / "usv_twin_thruster"
ESSO_DIR = SHARED_DATA / "esso_osaka"
REAL_LOGS_DIR = SHARED_DATA / "real_logs"
VTEC_DIR = SHARED_DATA / "vtec_usv"


def _data_dir(path: Path) -> Path:
    if not path.is_dir():
        pytest.skip(f"real data not found at {path} (../shared/data is not beside the repo)")
    return path


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


@pytest.fixture(scope="session")
def esso_dir() -> Path:
    """Folder of the nine Esso Osaka pond runs (CSV); skipped when absent."""
    return _data_dir(ESSO_DIR)


@pytest.fixture(scope="session")
def real_logs_dir() -> Path:
    """Folder of the public sample logs of real devices and gateways; skipped when absent."""
    return _data_dir(REAL_LOGS_DIR)


@pytest.fixture(scope="session")
def vtec_dir() -> Path:
    """Folder of the VTec S3 twin-thruster USV ROS 1 bags; skipped when absent."""
    return _data_dir(VTEC_DIR)


def pytest_sessionstart(session: pytest.Session) -> None:
    """Before the xdist workers start: compile the integration core (its chunk driver once,
    then every model kind's code, two processes side by side) into numba's disk cache
    (otherwise every worker compiles every kind it meets: about half of a cold run's CPU).
    Skipped in a worker and without xdist."""
    cfg = session.config
    if hasattr(cfg, "workerinput") or not getattr(cfg.option, "numprocesses", None):
        return
    # the chunk driver is the same for every kind: compiled first, once, with the smallest
    # kind; then the other kinds, the largest (most parameters: longest compile) first, dealt to
    # the two processes
    names = sorted(registry.names(), key=lambda k: -registry.get(k).n_params)
    script = str(Path(__file__).with_name("precompile.py"))
    subprocess.run([sys.executable, script, names[-1]], env=dict(os.environ), check=False)
    names = names[:-1]
    procs = [subprocess.Popen([sys.executable, script, *names[i::2]], env=dict(os.environ))
             for i in range(2)]
    for p in procs:
        p.wait()
