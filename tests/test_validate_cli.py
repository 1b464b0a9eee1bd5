"""``usvid validate`` and ``identify --validate``: the manoeuvre of each log, measured vs
predicted metrics (the prediction is ``usvid simulate`` with the detected settings), free-run
replay errors, per-log trimming, mixed-rate logs."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import browser
from usvid.cli import main
from usvid.identify.series import IdentificationWarning
from usvid.identify.validation import metric_error
from usvid.io.modelfile import save_model
from usvid.io.writers import write_csv
from usvid.models import IdealServo, Nomoto1, VesselModel
from usvid.sim import Turning, ZigZag, simulate
from usvid.trial import Vessel

K, T, U, L = 0.3, 5.0, 2.0, 6.0  # Nomoto gain [1/s], time constant [s], speed [m/s], length [m]
RATE = 10.0  # helm rate [deg/s]
ARTIFACTS = Path(__file__).resolve().parent / "artifacts"


def _model() -> VesselModel:
    return VesselModel(Nomoto1(K=K, T=T), servo=IdealServo(math.radians(35), math.radians(RATE)),
                       vessel=Vessel(length=L, speed=U))


def _log(path, logic, t_end, dt, seed=0):
    """A simulated log (heading noise 0.05 deg, positions 2 cm) written as CSV; its spec."""
    res = simulate(_model(), logic, t_end=t_end, dt=0.01, u0=U,
                   channels=("x", "y", "psi", "r", "delta", "U"))
    tr = res.to_trial(0, name=path.stem)
    m = int(round(dt / 0.01))
    data = tr.data.iloc[::m].reset_index(drop=True)
    rng = np.random.default_rng(seed)
    data["psi"] += rng.normal(0, math.radians(0.05), len(data))
    data["x"] += rng.normal(0, 0.02, len(data))
    data["y"] += rng.normal(0, 0.02, len(data))
    tr = tr.with_data(data)
    spec = path.with_suffix(".yaml")
    write_csv(tr, path, spec_path=spec)
    return spec


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("val")
    model = d / "truth.json"
    save_model(_model(), model)
    zz = d / "zz.csv"
    spec = _log(zz, ZigZag(math.radians(20), math.radians(20), t_start=5.0), 100.0, 0.1)
    tc = d / "tc.csv"
    _log(tc, Turning(math.radians(-25), t_start=5.0), 80.0, 0.1, seed=1)
    zz8 = d / "zz8.csv"  # the same zig-zag logged at 8 Hz (a second logger's rate)
    _log(zz8, ZigZag(math.radians(15), math.radians(15), t_start=5.0), 100.0, 0.125, seed=2)
    return {"model": model, "zz": zz, "tc": tc, "zz8": zz8, "spec": spec}


def _approx_equal(a, b) -> bool:
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(
            _approx_equal(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return isinstance(b, list) and len(a) == len(b) and all(
            _approx_equal(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, float) and isinstance(b, float):
        return a == pytest.approx(b, rel=1e-9, nan_ok=True)
    return a == b


def _run(capsys, *args):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out


def test_validate_true_model_predicts_the_measured_zigzag_and_turning(files, capsys):
    code, out = _run(capsys, "validate", files["model"], files["zz"], files["tc"],
                     "--format", files["spec"], "--json")
    assert code == 0, out.err
    rows = json.loads(out.out)["validation"]
    assert [r["manoeuvre"] for r in rows] == ["zigzag", "turning"]
    for r in rows:
        assert set(r) >= {"trial", "manoeuvre", "measured", "predicted", "error", "replay"}
    zz, tc = rows
    assert zz["settings"]["first"] == 1 and tc["settings"]["first"] == -1
    assert zz["settings"]["delta_deg"] == pytest.approx(20.0, abs=0.05)
    # the switching angle detected from the log, not a rounded standard value
    assert zz["settings"]["psi_deg"] == pytest.approx(20.0, abs=0.5)
    assert zz["settings"]["speed_m_s"] == pytest.approx(U, rel=1e-3)
    # the log's own model: predicted = measured up to the heading noise (0.05 deg smoothed over
    # 2 s, ~0.02 deg) and the 0.1-s sampling of the crossings (0.03 s x 6 deg/s); 0.15 deg
    assert np.max(np.abs(zz["error"]["overshoot_deg"][:3])) < 0.15
    assert abs(zz["error"]["period_s"]) < 0.1
    # turning: 2-cm positions on a ~13 m circle; 1 % of the diameter
    assert abs(tc["error"]["tactical_diameter_m"]) < 0.01 * tc["measured"]["tactical_diameter_m"]
    # the free-run replay of the true model: only the heading noise remains (0.05 deg)
    assert zz["replay"]["psi_rms_deg"] < 0.1 and tc["replay"]["track_rms_m"] < 0.2


def test_prediction_is_usvid_simulate_with_the_detected_settings(files, capsys):
    code, out = _run(capsys, "validate", files["model"], files["zz"], "--format", files["spec"],
                     "--json")
    row = json.loads(out.out)["validation"][0]
    s = row["settings"]
    code, out2 = _run(capsys, "simulate", "zigzag", files["model"], "--delta-deg", s["delta_deg"],
                      "--psi-deg", s["psi_deg"], "--speed", s["speed_m_s"], "--t-end",
                      s["t_end_s"], "--json")
    assert code == 0
    sim = json.loads(out2.out)
    assert row["predicted"]["overshoot_deg"] == sim["overshoot_deg"]  # one code path
    assert row["predicted"]["period_s"] == sim["period_s"]


def test_identify_validate_gives_the_rows_of_validate(files, tmp_path, capsys):
    # two logs at 10 Hz and 8 Hz: resampled onto one grid (it exited 2 before)
    with pytest.warns(IdentificationWarning, match="different sample rates"):
        code, out = _run(capsys, "identify", files["zz"], files["zz8"], "--format",
                         files["spec"], "--model", "nomoto1", "--validate", files["tc"],
                         "--out", tmp_path / "m.json", "--json")
    assert code == 0, out.err
    s = json.loads(out.out)
    # Euler-free simulated logs with 0.05-deg noise: K and T within 2 %
    assert s["params"]["K"] == pytest.approx(K, rel=0.02)
    assert s["params"]["T"] == pytest.approx(T, rel=0.02)
    code, out = _run(capsys, "validate", tmp_path / "m.json", files["tc"], "--format",
                     files["spec"], "--json")
    v = json.loads(out.out)["validation"][0]
    row = s["validation"][0]
    for key in ("trial", "manoeuvre", "measured", "predicted", "error", "replay", "settings"):
        # the model file round-trips its parameters through JSON text: rounding only
        assert _approx_equal(row[key], v[key]), key
    assert "window_s" in row["metrics"]  # the windowed metrics keep their window's label


def test_trimmed_logs(files, capsys):
    code, out = _run(capsys, "validate", files["model"], f"{files['zz']}:0:60",
                     "--format", files["spec"], "--json")
    assert code == 0, out.err
    row = json.loads(out.out)["validation"][0]
    assert row["replay"]["duration_s"] == pytest.approx(60.0, abs=0.2)
    code, out = _run(capsys, "validate", files["model"], files["zz"], "--t-start", "10",
                     "--format", files["spec"], "--json")
    # from 10 s on the record starts mid-manoeuvre: not a standard zig-zag any more
    row = json.loads(out.out)["validation"][0]
    assert row["manoeuvre"] == "other" and row["replay"]["duration_s"] == pytest.approx(90, abs=.2)


@pytest.mark.parametrize("arg,needle", [
    ("{zz}:50:20", "must be after the start"),
    ("{zz}:a:20", "is not a number of seconds"),
    ("{zz}:500:", "holds 0 record"),
])
def test_bad_trimming_is_exit_2(files, capsys, arg, needle):
    code, out = _run(capsys, "validate", files["model"], arg.format(zz=files["zz"]),
                     "--format", files["spec"])
    assert code == 2
    assert needle in out.err and out.err.count("\n") == 1


def test_bad_psi_deg_names_the_option(files, capsys):
    code, out = _run(capsys, "validate", files["model"], files["zz"], "--format", files["spec"],
                     "--psi-deg", "-3")
    assert code == 2 and "--psi-deg" in out.err


def test_metric_error_hand_values():
    e = metric_error({"overshoot_deg": [5.0, 6.0, 7.0], "period_s": 10.0, "x": 1.0},
                     {"overshoot_deg": [4.0, 6.5], "period_s": math.nan}, ["overshoot_deg",
                                                                           "period_s", "x"])
    assert e["overshoot_deg"] == [1.0, -0.5]
    assert math.isnan(e["period_s"]) and "x" not in e


def test_identify_report_separates_training_and_held_out(files, tmp_path, capsys):
    rep = tmp_path / "rep"
    code, out = _run(capsys, "identify", files["zz"], "--format", files["spec"], "--model",
                     "nomoto1", "--validate", files["tc"], "--out", tmp_path / "m.json",
                     "--report", rep, "--json")
    assert code == 0, out.err
    assert json.loads(out.out)["report"] == str(rep / "report.html")
    run = json.loads((rep / "run.json").read_text())
    assert [e["trial"] for e in run["training"]] == ["zz"]
    assert [e["trial"] for e in run["held_out"]] == ["tc"]
    # the 95 % band from the parameter covariance contains the true-model replay
    assert "psi_lo" in run["training"][0]["band"]
    corr = run["model"]["correlation"]
    assert corr["names"][:2] == ["K", "T"] and corr["matrix"][0][0] == pytest.approx(1.0)
    text = (rep / "report.html").read_text()
    assert "Training trials" in text and "Held-out trials" in text
    assert "does not apply" in text  # IMO MSC.137(76): ships of 100 m and over; L = 6 m
    assert "steady turning diameter" in text and "95 % prediction band" in text
    # usvid report DIR rebuilds the same page from run.json
    (rep / "report.html").unlink()
    assert main(["report", str(rep)]) == 0
    assert (rep / "report.html").read_text() == text
    if browser.find_chromium() is not None:
        check = browser.check_html(rep / "report.html", timeout=120)
        assert check.errors == [], check.errors
        shot = browser.screenshot(rep / "report.html", ARTIFACTS / "report_identify.png",
                                  height=2600, timeout=120)
        assert shot.stat().st_size > 50_000  # figures drawn (a blank page is ~5 kB)
