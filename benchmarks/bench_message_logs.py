"""Benchmark: read a one-hour log in each message-log format (ROS 2 MCAP and sqlite3, ROS 1 bag,
PX4 ULog, ArduPilot DataFlash, MAVLink tlog) and in three NMEA 2000 wire formats (candump -L,
SeaSmart $PCDIN, EByte binary) with usvid's reader and with the library's own plain loop over the
same file.

The log: a zig-zagging vessel at 10 Hz (position, velocity, heading, yaw rate, rudder angle and
command, engine speed every 0.1 s), written by usvid's writers (``write_rosbag``, ``write_ulog``,
``write_dataflash``, ``write_tlog``, ``write_nmea2000``). The library loop is what a user of the
library writes to get at the data: rosbags ``AnyReader.messages()`` + ``deserialize`` of every
message; pyulog ``ULog(path)``; pymavlink ``DFReader_binary`` / ``mavlink_connection`` +
``recv_msg()`` until the end; nmea2000 ``NMEA2000Decoder(format).decode()`` of every line (text)
or 13-byte packet (EByte). Prints records (messages in the file), seconds and records/s for both,
and their ratio (aim: usvid within 1.5x of the library loop, i.e. ratio <= 1.5).

Run: ``.venv/bin/python benchmarks/bench_message_logs.py [--minutes 60]``
"""

from __future__ import annotations

import argparse
import contextlib
import io
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from usvid import Trial
from usvid.io import read_trial
from usvid.io.ardupilot import write_dataflash, write_tlog
from usvid.io.n2k import write_nmea2000
from usvid.io.rosbag import write_rosbag
from usvid.io.ulog import write_ulog


def synthetic_trial(minutes: float, rate_hz: float = 10.0) -> Trial:
    t = np.round(np.arange(0.0, minutes * 60.0, 1.0 / rate_hz), 6)
    delta = np.radians(20.0) * np.sign(np.sin(2 * np.pi * t / 60.0))
    r = np.convolve(delta, np.full(20, 0.05 * 0.7), mode="same")
    psi = np.cumsum(r) / rate_hz
    return Trial(pd.DataFrame({
        "t": t, "lat": 38.86 + 1e-5 * np.cumsum(np.cos(psi)) / rate_hz,
        "lon": 121.55 + 1e-5 * np.cumsum(np.sin(psi)) / rate_hz, "sog": 5.0 + 0 * t,
        "cog": psi % (2 * np.pi), "psi": psi % (2 * np.pi), "r": r, "delta": delta,
        "delta_cmd": delta, "n": 48.0 + 0 * t, "u": 5.0 + 0 * t, "v": 0.1 * r}),
        meta={"t0_utc": "2025-06-01T10:00:00+00:00"})


def lib_rosbag(p: Path) -> int:
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    with AnyReader([p], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as r:
        n = 0
        for conn, _, raw in r.messages():
            r.deserialize(raw, conn.msgtype)
            n += 1
    return n


def lib_ulog(p: Path) -> int:
    from pyulog import ULog

    u = ULog(str(p))
    return sum(len(d.data["timestamp"]) for d in u.data_list)


def lib_dataflash(p: Path) -> int:
    from pymavlink import DFReader

    with contextlib.redirect_stdout(io.StringIO()):
        r = DFReader.DFReader_binary(str(p))
        n = 0
        while r.recv_msg() is not None:
            n += 1
    return n


def lib_tlog(p: Path) -> int:
    from pymavlink import mavutil

    m = mavutil.mavlink_connection(str(p))
    n = 0
    while m.recv_msg() is not None:
        n += 1
    return n


def lib_n2k(fmt: str):
    def run(p: Path) -> int:
        from nmea2000.decoder import NMEA2000Decoder
        from nmea2000.input_formats import N2KFormat

        dec = NMEA2000Decoder(N2KFormat(fmt), units="si")
        if fmt == "ebyte":
            blob = p.read_bytes()
            recs = [blob[i:i + 13] for i in range(0, len(blob), 13)]
        else:
            recs = p.read_text().splitlines()
        for r in recs:
            dec.decode(r)
        return len(recs)

    return run


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--minutes", type=float, default=60.0)
    args = ap.parse_args()
    tr = synthetic_trial(args.minutes)
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        cases = [
            ("ROS 2 MCAP", lambda: write_rosbag(tr, d / "mcap", storage="mcap"), lib_rosbag),
            ("ROS 2 sqlite3", lambda: write_rosbag(tr, d / "db3", storage="sqlite3"),
             lib_rosbag),
            ("ROS 1 bag", lambda: write_rosbag(tr, d / "log.bag", storage="ros1"), lib_rosbag),
            ("PX4 ULog", lambda: write_ulog(tr, d / "log.ulg"), lib_ulog),
            ("DataFlash", lambda: write_dataflash(tr, d / "log.bin"), lib_dataflash),
            ("MAVLink tlog", lambda: write_tlog(tr, d / "log.tlog"), lib_tlog),
            *((f"N2K {f}", (lambda f=f: write_nmea2000(tr, d / f"n2k_{f}.log", f)), lib_n2k(f))
              for f in ("candump3", "pcdin", "ebyte")),
        ]
        print(f"one log of {args.minutes:g} min, {len(tr)} rows at 10 Hz, 7-8 message types "
              "(NMEA 2000: 7 PGNs, + System Time in EByte)")
        print(f"{'format':14s} {'records':>9s} {'usvid s':>8s} {'usvid rec/s':>12s} "
              f"{'lib s':>7s} {'lib rec/s':>10s} {'ratio':>6s}")
        for name, write, lib in cases:
            t0 = time.perf_counter()
            p = write()
            tw = time.perf_counter() - t0
            t0 = time.perf_counter()
            n = lib(p)
            tl = time.perf_counter() - t0
            t0 = time.perf_counter()
            out = read_trial(p)
            tu = time.perf_counter() - t0
            assert len(out) > 0
            print(f"{name:14s} {n:9d} {tu:8.2f} {n / tu:12.0f} {tl:7.2f} {n / tl:10.0f} "
                  f"{tu / tl:6.2f}   (written in {tw:.1f} s)", flush=True)


if __name__ == "__main__":
    main()
