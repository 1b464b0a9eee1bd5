"""CLI: ``usvid audit`` and ``usvid metrics`` driven through usvid.cli.main."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from usvid.cli import main

HSVA = "HSVA_CPMC_KVLCC2_Z_{}.dat"


def run_json(capsys, argv, expect=0):
    code = main(argv)
    out = capsys.readouterr()
    assert code == expect, out.err
    return json.loads(out.out)


def test_audit_catalogue_spec_names_the_problems(capsys, hsva_dir):
    # error findings: exit code 3, with the whole JSON on stdout
    out = run_json(capsys, ["audit", str(hsva_dir / HSVA.format("10_10_S")),
                            "--format", "hsva_kvlcc2_catalogue", "--json"], expect=3)
    assert out["rejected"] == {} and out["samples"] == 1341
    codes = {f["code"]: f for f in out["findings"]}
    assert codes["yaw_rate_column"]["data"]["yaw_rate_channel"] == "p"
    assert codes["rudder_sign"]["severity"] == "error"
    assert out["counts"]["error"] == 2


def test_audit_shipped_spec_clean(capsys, hsva_dir):
    out = run_json(capsys, ["audit", str(hsva_dir / HSVA.format("20_10_P")),
                            "--format", "hsva_kvlcc2", "--json"])
    assert out["counts"]["error"] == 0 and out["counts"]["warning"] == 0


def test_audit_twin_by_spec_path(capsys, twin_dir):
    from usvid.io import shipped_spec_path

    out = run_json(capsys, ["audit", str(twin_dir / "boat1_2_sin.xlsx"), "--format",
                            str(shipped_spec_path("twin_thruster_xlsx")), "--json"])
    codes = {f["code"]: f for f in out["findings"]}
    # no false alarms: the PWM commands follow the yaw rate (through the hull) but are no yaw
    # rate; the GNSS heading holds values in turns (no glitches)
    assert not {"yaw_rate_found", "yaw_rate_weak", "heading_glitch"} & set(codes)
    assert out["counts"]["error"] == 0
    assert codes["position_scale"]["data"]["factor"] == pytest.approx(1.1117, abs=0.001)
    assert codes["stale_gnss_fix"]["data"]["rate"] == pytest.approx(0.452, abs=0.002)


@pytest.mark.parametrize(("run", "first"), [("10_10_S", 9.7), ("20_10_P", 12.0)])
def test_metrics_hsva_first_overshoot(capsys, hsva_dir, run, first):
    out = run_json(capsys, ["metrics", str(hsva_dir / HSVA.format(run)),
                            "--format", "hsva_kvlcc2", "--json"])
    assert out["count"] == 1 and out["kind"] == "zigzag"
    # acceptance: +-0.3 deg; the same keys as `usvid simulate zigzag`
    assert out["overshoot_deg"][0] == pytest.approx(first, abs=0.3)
    for key in ("overshoot_deg", "period_s", "initial_turning_time_s", "time_to_check_yaw_s"):
        assert key in out and key in out["manoeuvres"][0]
    assert out["rejected"] == {}


def test_metrics_twin_circle_turning_keys(capsys, twin_dir):
    out = run_json(capsys, ["metrics", str(twin_dir / "boat1_2_circle.xlsx"),
                            "--format", "twin_thruster_xlsx", "--json"])
    for key in ("advance_m", "transfer_m", "tactical_diameter_m", "steady_diameter_m",
                "steady_yaw_rate_rad_s", "steady_speed_m_s"):
        assert key in out
    assert out["steady_diameter_m"] == pytest.approx(45.0, abs=1.0)  # see test_manoeuvres


def test_metrics_text_output_and_no_manoeuvre(capsys, tmp_path):
    t = np.arange(0, 60, 0.1)
    p = tmp_path / "straight.csv"
    pd.DataFrame({"t": t, "x": 1.5 * t, "y": 0 * t, "psi": 0 * t, "delta": 0 * t}).to_csv(
        p, index=False)
    out = run_json(capsys, ["metrics", str(p), "--format", _csv_spec(tmp_path), "--json"])
    assert out["count"] == 0 and "no zig-zag" in out["message"]
    assert main(["metrics", str(p), "--format", _csv_spec(tmp_path)]) == 0
    assert "no zig-zag" in capsys.readouterr().out


def _csv_spec(tmp_path) -> str:
    spec = tmp_path / "csv.yaml"
    spec.write_text(
        "reader: table\ndelimiter: ','\nheader: true\ncolumns:\n"
        "  t: {col: t, unit: s}\n  x: {col: x, unit: m}\n  y: {col: y, unit: m}\n"
        "  psi: {col: psi, unit: rad}\n  delta: {col: delta, unit: rad}\n",
        encoding="utf-8")
    return str(spec)


def test_text_audit_prints_table(capsys, hsva_dir):
    assert main(["audit", str(hsva_dir / HSVA.format("10_10_S")),
                 "--format", "hsva_kvlcc2_catalogue"]) == 3  # error findings
    out = capsys.readouterr().out
    assert "yaw_rate_column" in out and "rudder_sign" in out


@pytest.mark.parametrize("cmd", ["audit", "metrics"])
def test_wholly_bad_log_exits_2_with_one_line(capsys, tmp_path, cmd):
    bad = tmp_path / "bad.dat"
    bad.write_text("not a log\n", encoding="utf-8")
    assert main([cmd, str(bad), "--format", "hsva_kvlcc2"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("usvid: error:") and "\n" not in err
    # a log whose records are all rejected: 4 header lines and rows of text
    bad.write_text("h\nh\nh\nh\n" + "a b c d e f g h i j k l\n" * 5, encoding="cp1252")
    assert main([cmd, str(bad), "--format", "hsva_kvlcc2"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("usvid: error:") and "\n" not in err


def test_missing_file_and_unknown_spec_exit_2(capsys, tmp_path):
    assert main(["audit", str(tmp_path / "nope.dat"), "--format", "hsva_kvlcc2"]) == 2
    assert "no such file" in capsys.readouterr().err
    (tmp_path / "x.dat").write_text("1 2\n", encoding="utf-8")
    assert main(["metrics", str(tmp_path / "x.dat"), "--format", "no_such_spec"]) == 2
    assert "format spec" in capsys.readouterr().err
    assert main(["metrics", str(tmp_path / "x.dat"), "--format", "hsva_kvlcc2",
                 "--psi-deg", "-1"]) == 2
    assert "--psi-deg" in capsys.readouterr().err
