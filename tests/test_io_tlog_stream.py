"""The tlog reader's loop over the log's bytes (io.ardupilot._TlogStream) yields message for
message, time stamp for time stamp, what pymavlink's ``mavlink_connection(tlog).recv_msg()``
returns, and fails where it fails, on a valid log and on binary mutations of it (damaged first
packets, whose recovery depends on what pymavlink's index pass leaves in the parser, included).
"""

from __future__ import annotations

import contextlib
import io
import random

import pytest

from fuzzing import binary_mutate, put

pytest.importorskip("pymavlink")

from test_io_message_logs import small_trial  # noqa: E402
from usvid.io.ardupilot import _FAILED, _TlogStream, write_tlog  # noqa: E402


def _pymavlink(path) -> list:
    from pymavlink import mavutil

    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        try:
            mlog = mavutil.mavlink_connection(str(path), notimestamps=False,
                                              robust_parsing=True)
        except Exception as exc:  # noqa: BLE001
            return [("open failed", type(exc).__name__)]
        out = []
        while True:
            try:
                m = mlog.recv_msg()
            except Exception:  # noqa: BLE001
                out.append(("failed",))
                continue
            if m is None:
                break
            out.append((m.get_type(), bytes(m.get_msgbuf()), m._timestamp))
        out.append(("left", mlog.mav.buf_len()))
        mlog.close()
    return out


def _ours(path) -> list:
    from pymavlink import mavutil

    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        conn = mavutil.mavlogfile(str(path), notimestamps=False, robust_parsing=True)
        try:
            stream = _TlogStream(conn, conn.f.read())
            try:
                stream.index()
            except Exception as exc:  # noqa: BLE001
                return [("open failed", type(exc).__name__)]
            out = [("failed",) if m is _FAILED
                   else (m.get_type(), bytes(m.get_msgbuf()), m._timestamp)
                   for m in stream.messages()]
            out.append(("left", conn.mav.buf_len()))
        finally:
            conn.close()
    return out


def test_tlog_stream_is_pymavlinks_reading(tmp_path):
    p = write_tlog(small_trial(T=1.0), tmp_path / "log.tlog")
    base = p.read_bytes()
    assert _ours(p) == _pymavlink(p)
    for seed in range(300):
        put(p, binary_mutate(base, random.Random(f"tlog-stream:{seed}")))
        assert _ours(p) == _pymavlink(p), seed
