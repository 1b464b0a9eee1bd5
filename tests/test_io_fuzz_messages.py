"""Property-based robustness of the message-log readers (ROS bags, ULog, DataFlash, tlog): random
mutations of valid logs and random bytes never raise anything but a UsvidError subclass, and what
is returned honours the Trial contract (bounded examples so the file stays fast)."""

from __future__ import annotations

import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from usvid.errors import UsvidError
from usvid.io import read_trial

pytest.importorskip("rosbags")
pytest.importorskip("pyulog")
pytest.importorskip("pymavlink")

from test_io_fuzz import _mutate, mutation  # noqa: E402
from test_io_message_logs import PRESET, WRITERS, small_trial  # noqa: E402

# no shrinking phase: a failure is reported as generated (shrinking bag files takes minutes)
SETTINGS = settings(max_examples=10, deadline=None, derandomize=True,
                    phases=[Phase.explicit, Phase.reuse, Phase.generate],
                    suppress_health_check=[HealthCheck.too_slow,
                                           HealthCheck.function_scoped_fixture])
_BASE: dict[str, Path] = {}


def _base(fmt: str) -> Path:
    if fmt not in _BASE:
        d = Path(tempfile.mkdtemp(prefix="usvid-fuzz-"))
        _BASE[fmt] = WRITERS[fmt](small_trial(T=1.0), d)
    return _BASE[fmt]


def _check(fmt: str, ops) -> None:
    src = _base(fmt)
    with tempfile.TemporaryDirectory() as d:
        if src.is_dir():
            q = Path(d) / "bag"
            shutil.copytree(src, q)
            (f,) = [x for x in q.iterdir() if x.suffix in (".mcap", ".db3")]
        else:
            q = f = Path(d) / src.name
            shutil.copyfile(src, q)
        f.write_bytes(_mutate(f.read_bytes(), ops))
        for spec in (None, PRESET[fmt]):
            try:
                tr = read_trial(q, spec)
            except UsvidError:
                continue
            t = tr.t
            assert np.all(np.isfinite(t)) and np.all(np.diff(t) > 0)
            assert all(isinstance(v, int) and v > 0 for v in tr.rejected.values())


@pytest.mark.slow
@pytest.mark.parametrize("fmt", list(WRITERS))
@SETTINGS
@given(ops=st.lists(mutation, min_size=1, max_size=4))
def test_mutated_message_logs_never_escape(fmt, ops):
    _check(fmt, ops)


@SETTINGS
@given(blob=st.binary(max_size=300), fmt=st.sampled_from(list(WRITERS)))
def test_random_bytes_with_a_message_spec_never_escape(blob, fmt):
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "log.dat"
        p.write_bytes(blob)
        try:
            read_trial(p, PRESET[fmt])
        except UsvidError:
            pass
