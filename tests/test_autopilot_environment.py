"""``usvid autopilot`` in wind and waves: the design in that environment, its ITAE (and the
reference's) in calm water and in the environment as new --json keys; calm water unchanged."""

from __future__ import annotations

import json

from usvid.cli import main

MODEL = {"usvid_model": 1, "kind": "nomoto1", "parameters": {"K": 0.5, "T": 2.0},
         "servo": {"kind": "ideal", "max_angle_deg": 35},
         "vessel": {"length": 5.0, "speed": 2.0, "mass": 800.0, "beam": 1.8, "draft": 0.3,
                    "frontal_area": 1.2, "lateral_area": 3.0}}
FAST = ["--samples", "0", "--horizon", "60", "--json"]


def _run(capsys, args):
    code = main(args)
    out = capsys.readouterr().out
    assert code == 0, out
    return json.loads(out)


def test_design_in_wind_and_waves_reports_calm_and_environment(tmp_path, capsys):
    p = tmp_path / "n.json"
    p.write_text(json.dumps(MODEL))
    calm = _run(capsys, ["autopilot", str(p), *FAST])
    assert calm["environment"] is None and calm["in_environment"] is None
    env = _run(capsys, ["autopilot", str(p), *FAST, "--wind-speed", "6", "--wind-dir-deg", "90",
                        "--hs", "0.3", "--tp", "3"])
    # the existing keys are all there; the pole placement is of the linear model: the same gains
    assert set(calm) == set(env)
    assert (env["kp"], env["kd"]) == (calm["kp"], calm["kd"])
    e = env["in_environment"]
    # the calm ITAE of the design is the calm run's own (same gains, seed, horizon, stream 0)
    assert e["itae_calm"] == calm["step"]["itae"]
    assert e["reference_itae_calm"] == calm["reference"]["step"]["itae"]
    assert e["itae_environment"] == env["step"]["itae"]
    # a steady 6 m/s beam wind on a PD loop (no integral) leaves a heading offset: the ITAE in
    # the wind is larger than in calm water, for the design and the reference
    assert e["itae_environment"] > e["itae_calm"]
    assert e["reference_itae_environment"] > e["reference_itae_calm"]
    assert env["environment"]["wind"]["speed_m_s"] == 6.0
    assert env["environment"]["wind"]["model"] == "blendermann1994"
    assert env["environment"]["waves"]["hs_m"] == 0.3


def test_environment_errors_exit_2(tmp_path, capsys):
    p = tmp_path / "n.json"
    p.write_text(json.dumps(MODEL))
    assert main(["autopilot", str(p), *FAST, "--tp", "3"]) == 2
    assert "--hs and --tp go together" in capsys.readouterr().err
    assert main(["autopilot", str(p), *FAST, "--current-speed", "nan"]) == 2
    assert "--current-speed must be in" in capsys.readouterr().err
