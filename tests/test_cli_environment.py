"""`usvid simulate ... --wind-speed/--wind-dir-deg/--current-speed/--current-dir-deg/--hs/--tp/
--wave-dir-deg`: the options reach the run, `--json` echoes them under "environment" (the
other keys unchanged, null in calm water), bad values exit 2 naming the option."""

from __future__ import annotations

import json

import pytest

from usvid.cli import main

K, T, U = 0.5, 2.0, 2.0


@pytest.fixture()
def nomoto_file(tmp_path):
    """A Nomoto 1 vessel with mass and windage (the rudder equivalent and the wind loads)."""
    p = tmp_path / "n.json"
    p.write_text(json.dumps({
        "usvid_model": 1, "kind": "nomoto1", "parameters": {"K": K, "T": T},
        "servo": {"kind": "ideal", "max_angle_deg": 35},
        "vessel": {"length": 5.0, "speed": U, "mass": 800.0, "beam": 1.8, "draft": 0.3,
                   "frontal_area": 1.2,
                   "lateral_area": 3.0}}))
    return p


def _json(capsys, args):
    code = main(args + ["--json"])
    out = capsys.readouterr().out
    assert code == 0, out
    return json.loads(out)


def test_calm_run_has_environment_null_and_the_same_keys(capsys, nomoto_file):
    calm = _json(capsys, ["simulate", "turning", str(nomoto_file), "--delta-deg", "20"])
    assert calm["environment"] is None
    zero = _json(capsys, ["simulate", "turning", str(nomoto_file), "--delta-deg", "20",
                          "--current-speed", "0"])
    assert [k for k in zero if k != "environment"] == [k for k in calm if k != "environment"]
    # a zero current is calm water: the same metrics (the environment's series variant of the
    # core: FMA contraction may differ in the last bits)
    for k in ("advance_m", "transfer_m", "tactical_diameter_m"):
        assert zero[k] == pytest.approx(calm[k], rel=1e-12)


def test_environment_round_trip(capsys, nomoto_file):
    d = _json(capsys, ["simulate", "zigzag", str(nomoto_file), "--wind-speed", "4",
                       "--wind-dir-deg", "90", "--current-speed", "0.5", "--current-dir-deg",
                       "270", "--hs", "0.3", "--tp", "3", "--wave-dir-deg", "45"])
    env = d["environment"]
    assert env["wind"]["speed_m_s"] == 4.0
    assert env["wind"]["direction_from_deg"] == pytest.approx(90.0)
    assert env["wind"]["model"] == "blendermann1994" and env["wind"]["reason"]
    assert env["wind"]["assumed"]  # the centroid defaults, the response kind's limits
    assert env["wind"]["rudder_equivalent"]["N_delta_N_m_per_rad"] > 0
    assert env["current"] == {"speed_m_s": 0.5, "direction_towards_deg": pytest.approx(270.0)}
    assert env["waves"]["hs_m"] == 0.3 and env["waves"]["tp_s"] == 3.0
    assert env["waves"]["direction_from_deg"] == pytest.approx(45.0)
    calm = _json(capsys, ["simulate", "zigzag", str(nomoto_file)])
    assert d["overshoot_deg"][0] != pytest.approx(calm["overshoot_deg"][0], rel=1e-6)


def test_current_drifts_the_turning_circle(capsys, nomoto_file):
    """A 0.5 m/s current towards the east on a turn that starts heading north: the transfer
    (east at 90 deg of heading change) grows by 0.5 m/s times the time to 90 deg."""
    args = ["simulate", "turning", str(nomoto_file), "--delta-deg", "20"]
    calm = _json(capsys, args)
    cur = _json(capsys, args + ["--current-speed", "0.5", "--current-dir-deg", "90"])
    # heading changes as in calm water; the position at that instant moves by 0.5 t (the
    # metrics interpolate between samples 0.02 s apart: 1e-6 m)
    assert cur["time_to_90_s"] == pytest.approx(calm["time_to_90_s"], rel=1e-9)
    assert cur["transfer_m"] == pytest.approx(calm["transfer_m"] + 0.5 * calm["time_to_90_s"],
                                              abs=1e-6)


@pytest.mark.parametrize("args, option", [
    (["--wind-speed", "-1"], "--wind-speed"),
    (["--wind-speed", "nan"], "--wind-speed"),
    (["--wind-speed", "3", "--wind-dir-deg", "720"], "--wind-dir-deg"),
    (["--current-speed", "25"], "--current-speed"),
    (["--current-speed", "0.5", "--current-dir-deg", "inf"], "--current-dir-deg"),
    (["--hs", "0", "--tp", "4"], "--hs"),
    (["--hs", "1", "--tp", "-4"], "--tp"),
    (["--hs", "1"], "--tp"),
    (["--wave-dir-deg", "10"], "--wave-dir-deg"),
    (["--wind-dir-deg", "10"], "--wind-dir-deg"),
])
def test_bad_environment_options_exit_2_naming_the_option(capsys, nomoto_file, args, option):
    code = main(["simulate", "turning", str(nomoto_file)] + args)
    err = capsys.readouterr().err
    assert code == 2
    assert option in err


def test_wind_without_windage_exits_2_naming_the_particulars(capsys, tmp_path):
    p = tmp_path / "bare.json"
    p.write_text(json.dumps({
        "usvid_model": 1, "kind": "nomoto1", "parameters": {"K": K, "T": T},
        "servo": {"kind": "ideal", "max_angle_deg": 35},
        "vessel": {"length": 5.0, "speed": U, "mass": 800.0}}))
    code = main(["simulate", "turning", str(p), "--wind-speed", "5"])
    err = capsys.readouterr().err
    assert code == 2
    assert "frontal_area" in err and "lateral_area" in err
