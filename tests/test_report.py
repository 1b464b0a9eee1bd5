"""Report module: HTML assembly from a run dict, no external URLs, headless Chromium rendering,
``usvid report`` CLI, run-file errors, and the python-control export of response models."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

import browser
from usvid.cli import main
from usvid.errors import UsvidError
from usvid.report.html import _kinds_compared, build_html, esc, external_urls, fit_label
from usvid.report.run import REPORT_FILE, load_run, save_run, write_report

ARTIFACTS = Path(__file__).resolve().parent / "artifacts"


def synthetic_run() -> dict:
    """A small run dict exercising every report section (values are arbitrary but plausible)."""
    t = np.linspace(0.0, 60.0, 301)
    psi = 20.0 * np.sin(t / 6.0)
    x, y = 5.0 * t, 8.0 * np.sin(t / 6.0)
    return {
        "usvid_run": 1,
        "title": "synthetic run",
        "settings": {"seed": 3, "quick": True},
        "vessel": {"length": 7.02, "beam": 2.6, "speed": 5.14},
        "steps": [
            {"name": "campaign", "status": "ok", "seconds": 1.2, "message": "6 trials"},
            {"name": "turning_diameter", "status": "unavailable", "seconds": 0.0,
             "message": "see http://example.com for why"},
        ],
        "campaign": {"trials": [{"name": "zz10", "kind": "zigzag", "delta_deg": 10.0,
                                 "psi_deg": 10.0, "duration_s": 60.0,
                                 "files": ["zz10.nmea", "zz10.candump"]}]},
        "audit": [{"trial": "zz10", "rejected": {"checksum": 2},
                   "findings": [{"severity": "warning", "code": "gnss_jump",
                                 "message": "position jump <b>", "count": 1}]}],
        "models": [{"kind": "nomoto1", "label": "Nomoto 1st order", "params": {"K": 0.70,
                    "T": 0.33}, "ci95": {"K": [0.69, 0.71], "T": [0.30, 0.36]},
                    "truth": {"K": 0.707, "T": 0.332}, "units": {"K": "1/s", "T": "s"}}],
        "validation": [{
            "trial": "zz10", "model": "nomoto1", "t": t.tolist(),
            "xy": {"measured": {"x": x.tolist(), "y": y.tolist()},
                   "simulated": {"x": x.tolist(), "y": (1.05 * y).tolist()}},
            "channels": [{"name": "psi", "ylabel": "psi [deg]",
                          "lines": {"measured": psi.tolist(), "simulated": (psi + 1).tolist()}},
                         {"name": "r", "ylabel": "r [deg/s]",
                          "lines": {"measured": np.gradient(psi, t).tolist()}}],
            "metrics": {"measured": {"period_s": 12.0, "overshoot_deg": [3.0, 4.0]},
                        "simulated": {"period_s": 12.4, "overshoot_deg": [3.2, 4.1]}},
            "imo": [{"name": "first_overshoot", "value": 3.0, "limit": 10.0, "passed": True}],
        }],
        "course_keeping": {"t": t.tolist(), "target_deg": 100.0,
                           "disturbance": np.sin(t).tolist(),
                           "runs": [{"label": "PD", "kp": 0.7, "ki": 0.0, "kd": 1.0,
                                     "psi_deg": (100 * (1 - np.exp(-t / 5))).tolist(),
                                     "delta_deg": (30 * np.exp(-t / 3)).tolist(),
                                     "itae": 38.0, "iae": 4.0}],
                           "paper_itae": {"PD": 38.6, "PID": 37.98}},
        "norrbin_fit": {"delta_deg": [10, 15, 25, 35], "r_deg_s": [7, 9, 12, 14],
                        "curve_delta_deg": [0, 35], "curve_r_deg_s": [0, 14]},
    }


def test_html_has_every_section_and_no_external_url(tmp_path: Path) -> None:
    run = synthetic_run()
    html = build_html(run)
    for heading in ("Pipeline", "Trials", "Data audit", "Identified models", "Validation",
                    "Course keeping", "Turning diameter"):
        assert heading in html
    # 3 validation/course figures + Norrbin fit = 4 embedded PNGs
    assert len(re.findall(r'<img src="data:image/png;base64,', html)) == 4
    assert external_urls(html) == []
    assert "http://example.com" not in html  # the step message URL was neutralised
    assert "position jump &lt;b&gt;" in html  # text from the run is escaped
    assert "not available: see" in html  # the unavailable step is named with its reason
    assert "@media print" in html
    # relative error of the identified parameter vs truth: (0.70 - 0.707)/0.707 = -1.0 %
    assert "-1.0 %" in html


def test_external_url_detector_and_escape() -> None:
    assert external_urls('<img src="https://cdn.example.org/x.js">') != []
    assert external_urls("<a href='//cdn.example.org/x'>") != []
    assert external_urls("data:image/png;base64,AAAA") == []
    assert external_urls(esc("go to https://evil.example.com/x")) == []


def test_write_report_is_atomic_and_deterministic(tmp_path: Path) -> None:
    run = synthetic_run()
    p1 = write_report(run, tmp_path)
    first = p1.read_bytes()
    p2 = write_report(run, tmp_path)
    assert p2.read_bytes() == first  # same run -> byte-identical report (PNG without timestamp)
    assert sorted(f.name for f in tmp_path.iterdir()) == [REPORT_FILE]  # no temp files left


def test_load_run_errors(tmp_path: Path) -> None:
    with pytest.raises(UsvidError, match="no run file"):
        load_run(tmp_path)
    (tmp_path / "run.json").write_text("{not json", encoding="utf-8")
    with pytest.raises(UsvidError, match="not a readable JSON"):
        load_run(tmp_path)
    (tmp_path / "run.json").write_text(json.dumps({"usvid_run": 99}), encoding="utf-8")
    with pytest.raises(UsvidError, match="usvid_run must be 1"):
        load_run(tmp_path)


def test_cli_report_regenerates(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    save_run(synthetic_run(), tmp_path)
    assert main(["report", str(tmp_path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert Path(out["report"]).is_file() and out["bytes"] > 10_000
    assert main(["report", str(tmp_path / "missing")]) == 2


@pytest.mark.skipif(browser.find_chromium() is None,
                    reason="chromium not installed (apt-get install chromium)")
def test_report_renders_in_headless_chromium(tmp_path: Path) -> None:
    path = write_report(synthetic_run(), tmp_path)
    check = browser.check_html(path)
    assert check.errors == [], check.errors
    assert len(check.images) == 4
    assert check.broken_images == []  # every figure decoded (naturalWidth > 0)
    shot = browser.screenshot(path, ARTIFACTS / "report_synthetic.png", height=2400)
    assert shot.stat().st_size > 20_000  # a blank page PNG is ~5 kB; the report is far larger


@pytest.mark.skipif(browser.find_chromium() is None,
                    reason="chromium not installed (apt-get install chromium)")
def test_chromium_probe_detects_broken_image_and_console_error(tmp_path: Path) -> None:
    """The harness can fail: a broken image and a console error are both reported."""
    bad = tmp_path / "bad.html"
    bad.write_text('<!DOCTYPE html><html><head></head><body><img alt="x" '
                   'src="data:image/png;base64,AAAA"><script>console.error("boom")</script>'
                   "</body></html>", encoding="utf-8")
    check = browser.check_html(bad)
    assert [im["alt"] for im in check.broken_images] == ["x"]
    assert any("boom" in e for e in check.errors)


def test_to_transfer_function_nomoto_and_servo() -> None:
    control = pytest.importorskip("control")
    from usvid.models import Nomoto1, Nomoto2, Norrbin
    from usvid.models.export import to_transfer_function
    from usvid.models.servo import SecondOrderServo

    K, T = 0.707, 0.332  # Mu et al. 2018 eq. 38 (consistent reading)
    sys = to_transfer_function(Nomoto1(K=K, T=T))
    assert control.dcgain(sys) == pytest.approx(K, rel=1e-12)
    assert control.poles(sys)[0].real == pytest.approx(-1.0 / T, rel=1e-12)
    # Nomoto 2: K (1 + T3 s)/((1 + T1 s)(1 + T2 s)) -> zero at -1/T3, poles at -1/T1, -1/T2
    sys2 = to_transfer_function(Nomoto2(K=0.5, T1=2.0, T2=0.5, T3=1.0))
    assert sorted(control.poles(sys2).real) == pytest.approx([-2.0, -0.5])
    assert control.zeros(sys2)[0].real == pytest.approx(-1.0)
    # Norrbin linearised at r = 0: K/(T s + n1); course-unstable n1 < 0 gives a RHP pole
    sys3 = to_transfer_function(Norrbin(K=0.3, T=2.0, n1=-0.5, n3=100.0))
    assert control.poles(sys3)[0].real == pytest.approx(0.25)
    # heading output adds an integrator; servo in series keeps the static gain (gain 1)
    psi = to_transfer_function(Nomoto1(K=K, T=T), output="psi")
    assert np.min(np.abs(control.poles(psi))) == pytest.approx(0.0, abs=1e-12)

    class Wrapped:  # a VesselModel-like object: .dynamics and .servo
        dynamics = Nomoto1(K=K, T=T)
        servo = SecondOrderServo(omega_n=1.3964, zeta=0.8526, delay=1.0)

    full = to_transfer_function(Wrapped(), include_servo=True, pade_order=2)
    assert control.dcgain(full) == pytest.approx(K, rel=1e-9)
    assert len(control.poles(full)) == 1 + 2 + 2  # Nomoto + servo + Pade(2)
    with pytest.raises(UsvidError, match="not a model parameter set"):
        to_transfer_function(object())
    with pytest.raises(UsvidError, match="output must be"):
        to_transfer_function(Nomoto1(K=K, T=T), output="x")


@pytest.mark.skipif(browser.find_chromium() is None,
                    reason="chromium not installed (apt-get install chromium)")
def test_report_prints_to_pdf(tmp_path: Path) -> None:
    path = write_report(synthetic_run(), tmp_path)
    pdf = browser.print_pdf(path, ARTIFACTS / "report_synthetic.pdf")
    data = pdf.read_bytes()
    assert data.startswith(b"%PDF")
    # print CSS starts every h2 section on a new page: 7 sections -> at least 7 pages
    assert len(re.findall(rb"/Type\s*/Page[^s]", data)) >= 7


def test_report_labels_units_of_vessel_fit_and_gains():
    run = {
        "vessel": {"length": 7.02, "displacement": 2.73},
        "models": [{"kind": "nomoto1", "params": {"K": 0.7}, "units": {"K": "1/s"},
                    "fit": {"r.rmse": 0.0037, "psi.max_error": 0.01, "r.nrmse": 0.03}},
                   {"kind": "servo", "params": {"gain": 1.0}, "units": {"gain": "-"},
                    "fit": {"rmse": 0.003}}],
        "course_keeping": {"runs": [{"label": "PD", "kp": 0.7, "ki": 0.0, "kd": 1.0,
                                     "itae": 58.5, "iae": 8.2, "max_rudder_deg": 35.0}]},
    }
    html = build_html(run)
    assert external_urls(html) == []
    # displacement is 2.73 m^3 (Mu et al. 2018 Table 1), not "SI" in general
    assert "<td>m^3</td>" in html and "value (SI)" not in html
    assert "r.rmse [rad/s] = " in html and "psi.max_error [rad] = " in html
    assert "rmse [rad] = " in html  # the servo's output is delta [rad]
    assert "ITAE [rad s^2]" in html and "Ki [1/s]" in html
    assert fit_label("u.rmse") == "u.rmse [m/s]" and fit_label("r2") == "r2 [-]"
    assert fit_label("window_s") == "window_s"


def test_kinds_compared_table_by_hand():
    # two kinds on a held-out zig-zag and a training turn: the cells are simulated minus
    # measured (first overshoot 12.5 - 12.0 = +0.50 deg; tactical diameter 21/20 - 1 = +5.0 %)
    zz = {"overshoot_deg": [12.0, 13.0]}
    val = [
        {"trial": "zigzag_20_20", "model": "nomoto1", "role": "held out",
         "fit": {"psi RMS error [deg]": 1.234},
         "metrics": {"measured": zz, "simulated": {"overshoot_deg": [12.5, 13.0]}}},
        {"trial": "zigzag_20_20", "model": "threedof", "role": "held out",
         "metrics": {"measured": zz, "simulated": {"overshoot_deg": [11.0]}}},
        {"trial": "turning_35", "model": "threedof", "role": "training",
         "metrics": {"measured": {"tactical_diameter_m": 20.0},
                     "simulated": {"tactical_diameter_m": 21.0}}},
    ]
    html = _kinds_compared(val)
    assert "<th>nomoto1</th>" in html and "<th>threedof</th>" in html
    assert "psi RMS 1.23 deg; 1st overshoot +0.50 deg" in html
    assert "1st overshoot -1.00 deg" in html
    assert "tactical diameter +5.0 %" in html
    assert "zigzag_20_20 (held out)" in html and "turning_35 (training)" in html
    # nomoto1 was not run on the turn: a dash, not a made-up number
    assert re.search(r"turning_35 \(training\)</td><td>-</td>", html)
