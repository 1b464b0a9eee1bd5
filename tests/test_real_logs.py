"""``usvid audit``, ``metrics`` and ``identify`` (the CLI, in process) on every public sample log of
``../shared/data/real_logs/`` (README there): what each log truly holds, written down per file
from reading it, and for all of them: exit codes 0, 2 or 3 only (never a traceback), no warning
text of numpy or pandas on stderr, sources never interleaved (every channel that several
senders give is reported with the one chosen), no silently collapsed records (samples lost to
shared time stamps are reported), and no error finding that is not true of the log.

The three commands on all 18 logs cost about 20 s of CPU (measured at load; arcturus_mav.tlog,
the slowest, 4 s for its audit: 3,000 MAVLink messages parsed by pymavlink one by one)."""

from __future__ import annotations

import contextlib
import copy
import io
import json
import warnings

import pytest

import usvid.prep.logs
from usvid.cli import main
from usvid.io import read_trial

#: Per log: the exit codes of audit / metrics / identify (nomoto1), the error findings of the
#: audit (exactly), findings that must be there and findings that must not, channels read,
#: and the channels several senders give (each reported, one chosen).
EXPECT: dict[str, dict] = {
    # ArduPilot SITL (HEARTBEAT type 10: a ground rover, not a boat), skid steering by
    # SERVO1/3_FUNCTION 73/74; it never moves (SOG 0) while its attitude estimate wanders,
    # both thrusters stay at neutral (the differential holds 0: nothing steered, true), and the
    # first 27 fixes are no fix (26 at lat = lon = 0, one of fix type 'no fix')
    "arcturus_mav.tlog": dict(codes=(3, 0, 2), errors={"actuator_constant"},
                              present={"not_a_vessel", "no_fix", "not_under_way",
                                       "not_checked_vehicle"},
                              absent={"yaw_rate_column", "thruster_sign", "position_jump"},
                              channels={"lat", "lon", "psi", "r", "n_port", "n_stbd", "phi"},
                              rejected={"no_fix": 27}),
    # candump without stamps, timed by the bus's System Time (PGN 126992); GNSS only
    "canboat_candumpSample1.txt": dict(codes=(0, 2, 2), present={"no_heading"},
                                       channels={"lat", "lon", "sog", "cog", "stw"}),
    # the same 20,000 lines twice (the copy dropped); two heading/rate senders (0x07 used,
    # 0x69 magnetic), two GNSS (0x21 used, 5.8 m from 0x07); a gateway stamping in bursts of
    # 1 ms (samples lost to shared stamps, reported); the gyro follows the heading loosely
    "canboat_dirona-actisense-serial.raw": dict(
        codes=(0, 0, 2), present={"log_repeated", "shared_time_stamp", "yaw_rate_weak"},
        absent={"yaw_rate_column", "heading_jump", "time_discontinuity"},
        channels={"psi", "psi_mag", "r", "phi", "theta", "lat", "lon", "wind_speed",
                  "wind_angle"},
        sources={"r": "0x07", "lat": "0x21", "cog": "0x21", "phi": "0x07"}),
    # iKonvert PDGY, milliseconds unpadded (no record out of order any more); its rate of turn
    # lags the heading's derivative by about 2 s (a filtered ROT: a warning, not "no yaw
    # rate"); a 29-s gap in the capture (its $PDGY status lines jump from 486 to 516 s)
    "canboat_ikonvert.log": dict(codes=(0, 0, 2),
                                 present={"yaw_rate_lag", "time_discontinuity",
                                          "heading_from_magnetic"},
                                 absent={"non_monotonic_time", "yaw_rate_column"},
                                 channels={"psi", "r"}),
    # 2.5 s of a Yacht Devices gateway: too short to judge; wind from two senders
    "canboat_merrimac-ydwg-2020.raw": dict(codes=(0, 0, 2), present={"too_short"},
                                           channels={"psi", "delta", "wind_speed",
                                                     "wind_dir_true", "phi"},
                                           sources={"wind_speed": "0x20"}),
    # 23,795 records stamped within 56 ms by the recorder: said, and nothing judged on it
    "canboat_raymarine-ev1.raw": dict(codes=(0, 0, 2),
                                      present={"time_stamps_collapsed", "shared_time_stamp",
                                               "too_short", "heading_magnetic"},
                                      channels={"psi", "r", "delta", "phi", "theta"}),
    # a rudder angle of -105 deg throughout: explained, no "hard-over"; the boat hardly moves
    "canboat_sample3_PCAN-View.trc": dict(codes=(0, 0, 2),
                                          present={"rudder_out_of_range", "not_under_way",
                                                   "no_turning"},
                                          absent={"saturation"},
                                          channels={"psi", "delta", "lat", "sog"}),
    # at the dock: two magnetic compasses 115 deg apart (0x17 used), the autopilot's rudder
    # order held at 0 while the rudder angle moves (a warning); no rudder-sign verdict
    "canboat_susteranna2020.raw": dict(
        codes=(0, 0, 2), present={"not_under_way", "actuator_constant"},
        absent={"rudder_sign", "yaw_rate_column"},
        channels={"psi", "r", "delta", "delta_cmd", "wind_speed", "wind_dir_true", "phi"},
        sources={"psi_mag": "0x17", "r": "0x17", "lat": "0x7F", "wind_speed": "0x21"}),
    # the raymarine capture again, as the NGT-1 recorded it (BST 93): 263 s of real time;
    # its 127257 yaw equals its magnetic 127250 heading (no variation logged)
    "canboat_ydnu-02-raymarine-ev1.dle": dict(codes=(0, 0, 2),
                                              present={"gateway_messages", "heading_magnetic"},
                                              absent={"time_stamps_collapsed",
                                                      "yaw_rate_column"},
                                              channels={"psi", "r", "delta", "phi", "theta"}),
    # ArduCopter 3.2 DataFlash: GPS without instance column, GPS week time, no rudder
    "peterbarker_1.BIN": dict(codes=(0, 0, 2), present={"not_a_vessel", "not_checked_vehicle"},
                              channels={"lat", "lon", "psi", "r", "phi", "theta", "p"},
                              t0_utc="2015-02-23"),
    "peterbarker_3.BIN": dict(codes=(0, 0, 2), present={"not_a_vessel"},
                              channels={"lat", "lon", "psi", "r", "phi"}, t0_utc="2015-06-28"),
    # PX4 multicopter without a GNSS fix; rates from sensor_combined (an older PX4)
    "pyulog_sample.ulg": dict(codes=(0, 0, 2), present={"not_a_vessel", "topic_alias"},
                              channels={"psi", "r", "phi", "theta", "p"}),
    # a VTOL; positions from vehicle_gps_position (1e-7 deg); 6.5 s
    "pyulog_sample_log_small.ulg": dict(codes=(0, 0, 2),
                                        present={"not_a_vessel", "topic_alias", "too_short"},
                                        channels={"lat", "lon", "psi", "r"}),
    "pyulog_sample_px4_events.ulg": dict(codes=(0, 0, 2), present={"not_a_vessel", "no_turning"},
                                         channels={"lat", "lon", "psi", "r", "n"}),
    # a yacht under way, one sender per quantity: nothing to say
    "signalk_aava-n2k.data": dict(codes=(0, 0, 2), warnings=set(),
                                  channels={"psi", "stw", "sog", "lat", "lon", "cog",
                                            "wind_speed", "wind_angle"}),
    # moored B&G: heading from HDG plus its variation; wind from MWV R/T and MWD
    "signalk_gofree-merrimac.log": dict(codes=(0, 0, 2),
                                        present={"heading_from_magnetic", "time_from_epoch",
                                                 "no_turning"},
                                        absent={"non_monotonic_time", "time_backwards"},
                                        channels={"psi", "wind_angle", "wind_dir_true",
                                                  "wind_angle_true", "lat", "stw"}),
    # GNSS only: one row per fix (VTG no longer doubles them)
    "signalk_gps.log": dict(codes=(0, 2, 2), present={"no_heading", "time_from_epoch"},
                            channels={"lat", "lon", "sog", "cog"}, rows=1202),
    # times only from GLL/ZDA (no date); no heading (HDT, HDM empty): true wind from the bow
    "signalk_plaka.log": dict(codes=(0, 2, 2), present={"no_heading", "wind_direction_unknown"},
                              channels={"lat", "lon", "sog", "stw", "wind_angle",
                                        "wind_angle_true", "wind_speed_true"}),
}
#: Text numpy or pandas puts in a warning.
NOISE = ("RuntimeWarning", "invalid value encountered", "Degrees of freedom", "Mean of empty",
         "FutureWarning", "DeprecationWarning", "SettingWithCopy", "divide by zero",
         "All-NaN slice")


def _run(argv):
    out, err = io.StringIO(), io.StringIO()
    with warnings.catch_warnings(), contextlib.redirect_stdout(out), \
            contextlib.redirect_stderr(err):
        warnings.simplefilter("always")
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


@pytest.fixture(scope="module")
def runs(real_logs_dir, tmp_path_factory):
    """The three commands on every log, each log read once: the commands' reader
    (``usvid.prep.logs.read_trial``) remembers a trial by path and spec and hands each later
    command a deep copy. Reading is ~80 % of the commands' CPU here (15 s for all 18 logs read
    four times); the first read is the audit's, under its stderr and warnings checks, and the
    test's own trial is the one the commands worked on (spec "auto", the commands' default)."""
    names = sorted(p.name for p in real_logs_dir.iterdir() if p.suffix not in (".md", ".parm"))
    assert names == sorted(EXPECT)  # every log of the folder is written down here
    model = tmp_path_factory.mktemp("models") / "m.json"
    read: dict[tuple[str, str], object] = {}

    def read_once(path, spec=None):
        key = (str(path), str(spec))
        if key not in read:
            read[key] = read_trial(path, spec)
        return copy.deepcopy(read[key])

    res = {}
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(usvid.prep.logs, "read_trial", read_once)
        for name in names:
            p = str(real_logs_dir / name)
            audit = _run(["audit", p, "--json"])
            res[name] = {
                "audit": audit,
                "report": json.loads(audit[1]),
                "metrics": _run(["metrics", p, "--json"]),
                "identify": _run(["identify", p, "--model", "nomoto1", "--out", str(model),
                                  "--json"]),
                "trial": read_once(p, "auto"),
            }
    assert len(read) == len(names)  # one read per log: the commands' spec is "auto"
    return res


@pytest.mark.parametrize("name", sorted(EXPECT))
def test_real_log(runs, name):
    r, want = runs[name], EXPECT[name]
    codes = tuple(r[c][0] for c in ("audit", "metrics", "identify"))
    assert codes == want["codes"], (name, [r[c][2][-300:] for c in ("metrics", "identify")])
    for c in ("audit", "metrics", "identify"):
        err = r[c][2]
        assert "Traceback" not in err and not [n for n in NOISE if n in err], (name, c, err)
    found = r["report"]["findings"]
    by = {}
    for f in found:
        by.setdefault(f["code"], []).append(f)
    errors = {f["code"] for f in found if f["severity"] == "error"}
    assert errors == want.get("errors", set()), (name, errors)
    assert want.get("present", set()) <= set(by), (name, want.get("present", set()) - set(by))
    assert not want.get("absent", set()) & set(by), (name, want.get("absent", set()) & set(by))
    if "warnings" in want:
        assert {f["code"] for f in found if f["severity"] == "warning"} == want["warnings"]
    # errors first, then warnings, then infos
    sev = [f["severity"] for f in found]
    assert sev == sorted(sev, key=["error", "warning", "info"].index), name
    # every error says what to do, with a format-spec line or the trim of the log
    for f in found:
        if f["severity"] == "error":
            assert "`" in f["message"] or "LOG:T0:T1" in f["message"], f["message"]
        assert "nan %" not in f["message"] and "+nan" not in f["message"]
    tr = r["trial"]
    assert want["channels"] <= set(tr.channels), (name, want["channels"] - set(tr.channels))
    for k, v in want.get("rejected", {}).items():
        assert tr.rejected.get(k) == v, (name, tr.rejected)
    if "rows" in want:
        assert len(tr) == want["rows"]
    if "t0_utc" in want:
        assert tr.meta["t0_utc"].startswith(want["t0_utc"])
        assert tr.duration < 3600.0  # GPS week time no longer mixed with boot time
    # no interleaved sources: each channel several senders give is reported, one chosen
    chosen = {k: v["chosen"] for k, v in tr.meta.get("sources", {}).items()}
    assert {f["channel"] for f in by.get("several_sources", [])} == set(chosen)
    for ch, src in want.get("sources", {}).items():
        assert chosen.get(ch) == src, (name, ch, chosen)
    # no silently collapsed records: samples lost to shared stamps are reported
    if tr.meta.get("superseded"):
        assert "shared_time_stamp" in by, name


@pytest.mark.parametrize("name", sorted(EXPECT))
def test_turning_circles_only_under_way(runs, name):
    """A turning circle is measured only where the vessel was under way: never a negative or
    vanishing diameter. arcturus_mav.tlog (a simulated skid-steer boat at rest, its heading
    turning 472 deg before its GPS lock, sog 0) measured one with a tactical diameter of
    -0.0008 m; now it says why there is none."""
    code, out, _ = runs[name]["metrics"]
    if code != 0:
        return
    j = json.loads(out)
    for m in j["manoeuvres"]:
        if m["kind"] == "turning":
            assert m["approach"]["speed_m_s"] is None or m["approach"]["speed_m_s"] >= 0.2
            assert m["tactical_diameter_m"] > 1.0, (name, m["tactical_diameter_m"])
    if name == "arcturus_mav.tlog":
        assert j["count"] == 0
        (f,) = j["findings"]
        assert f["code"] == "turn_not_under_way"
        assert f["data"]["heading_change_deg"] == pytest.approx(472, abs=1)
        assert f["data"]["median_speed_m_s"] == 0.0 and f["data"]["speed_from"] == "sog"
