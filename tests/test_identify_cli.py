"""``usvid identify``: model file written atomically and loadable, JSON summary, exit codes."""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pandas as pd
import pytest

from reference import nomoto_zoh_zigzag
from usvid.cli import main
from usvid.commands.identify import _print_summary
from usvid.identify.series import IdentificationWarning

SPEC = """reader: table
delimiter: ","
skip_rows: 1
columns:
  t:     {col: 0, unit: s}
  psi:   {col: 1, unit: deg}
  r:     {col: 2, unit: deg/s}
  delta: {col: 3, unit: deg}
vessel: {length: 7.0, speed: 3.0}
"""


def _write_log(path, delta_deg, seed=0):
    """A Nomoto K = 0.5 1/s, T = 3 s log at 10 Hz (Euler-integrated, small noise) as CSV."""
    rng = np.random.default_rng(seed)
    h = 0.1
    n = len(delta_deg)
    r = np.zeros(n)
    psi = np.zeros(n)
    d = np.radians(delta_deg)
    for k in range(n - 1):
        r[k + 1] = r[k] + h * (0.5 * d[k] - r[k]) / 3.0
        psi[k + 1] = psi[k] + h * r[k]
    rows = ["t,psi,r,delta"] + [
        f"{k * h:.2f},{math.degrees(psi[k]) + rng.normal(0, 0.05):.5f},"
        f"{math.degrees(r[k]) + rng.normal(0, 0.02):.5f},{delta_deg[k]:.4f}" for k in range(n)]
    path.write_text("\n".join(rows) + "\n")


@pytest.fixture()
def logs(tmp_path):
    spec = tmp_path / "spec.yaml"
    spec.write_text(SPEC)
    t = np.arange(0, 200, 0.1)
    a = tmp_path / "a.csv"
    _write_log(a, 15 * np.sign(np.sin(2 * np.pi * t / 25.0)))
    b = tmp_path / "b.csv"
    _write_log(b, 10 * np.sign(np.sin(2 * np.pi * t / 18.0)), seed=1)
    return spec, a, b


def test_identify_writes_model_file_and_json(logs, tmp_path, capsys):
    spec, a, b = logs
    out = tmp_path / "m.json"
    code = main(["identify", str(a), "--format", str(spec), "--model", "nomoto1",
                 "--method", "oe", "--validate", str(b), "--out", str(out), "--json"])
    assert code == 0
    s = json.loads(capsys.readouterr().out)
    # Euler-integrated truth K = 0.5, T = 3 (Euler at h/T = 0.03 shifts T by ~h/2 = 1.7 %)
    assert s["params"]["K"] == pytest.approx(0.5, rel=0.05)
    assert s["params"]["T"] == pytest.approx(3.0, rel=0.05)
    assert set(s["std_errors"]) == {"K", "T", "delta0"}
    assert s["fit"]["psi"]["r2"] > 0.99
    assert s["validation"][0]["metrics"]["psi"]["r2"] > 0.99
    d = json.loads(out.read_text())
    assert d["usvid_model"] == 1 and d["kind"] == "nomoto1"
    ident = d["identification"]
    assert ident["method"] == "oe"
    assert ident["data"] == [str(a)]
    assert len(ident["data_sha256"][str(a)]) == 64
    from usvid.io.modelfile import load_model

    m = load_model(out)
    assert m.dynamics.K == pytest.approx(s["params"]["K"])
    assert not list(tmp_path.glob(".m.json.*"))  # no temporary file left behind


def test_identify_human_summary(logs, tmp_path, capsys):
    spec, a, _ = logs
    code = main(["identify", str(a), "--format", str(spec), "--model", "norrbin",
                 "--method", "ls", "--out", str(tmp_path / "n.json")])
    assert code == 0
    text = capsys.readouterr().out
    assert "model norrbin (ls)" in text and "n3" in text


def test_identify_constant_rudder_is_exit_2(logs, tmp_path, capsys):
    spec, _, _ = logs
    c = tmp_path / "c.csv"
    _write_log(c, np.full(2000, 5.0))
    code = main(["identify", str(c), "--format", str(spec), "--model", "nomoto1",
                 "--out", str(tmp_path / "x.json")])
    assert code == 2
    err = capsys.readouterr().err
    assert "no excitation" in err
    assert not (tmp_path / "x.json").exists()


def test_identify_unknown_kind_is_exit_2(logs, tmp_path, capsys):
    spec, a, _ = logs
    code = main(["identify", str(a), "--format", str(spec), "--model", "abkowitz",
                 "--out", str(tmp_path / "x.json")])
    assert code == 2
    assert "--model 'abkowitz': not a model kind" in capsys.readouterr().err


def test_identify_kvlcc2_cli(hsva_dir, tmp_path, capsys):
    logs = [str(hsva_dir / f"HSVA_CPMC_KVLCC2_Z_{n}.dat") for n in ("10_05", "15_05", "20_05")]
    out = tmp_path / "kvlcc2.json"
    code = main(["identify", *logs, "--format", "hsva_kvlcc2", "--model", "nomoto1",
                 "--validate", str(hsva_dir / "HSVA_CPMC_KVLCC2_Z_10_10_P.dat"),
                 "--out", str(out), "--json"])
    assert code == 0
    s = json.loads(capsys.readouterr().out)
    # task: at model scale K ~ 0.05-0.3 1/s and T tens of seconds (L/U = 5.9 s)
    assert 0.05 < s["params"]["K"] < 0.5 and 5.0 < s["params"]["T"] < 60.0
    row = s["validation"][0]  # the one validation row of usvid validate
    assert row["manoeuvre"] == "zigzag"
    assert row["measured"]["overshoot_deg"][0] == pytest.approx(9.7, abs=0.1)


def test_summary_uses_the_interval_half_width_not_1_96_se(capsys):
    # commands/identify.py _print_summary printed 1.96 se even when the interval uses the
    # Student-t quantile (cluster-robust output error with few windows): here q = 2.571 (5 dof).
    s = {"kind": "nomoto1", "method": "oe", "model_file": None,
         "params": {"K": 0.3}, "std_errors": {"K": 0.01}, "ci95": {"K": [0.27429, 0.32571]},
         "fit": {}}
    _print_summary(s)
    out = capsys.readouterr().out
    assert "+- 0.0257 (95 %)" in out
    assert "0.0196" not in out


#: the format spec of the noise-free ZOH zig-zag logs (reference.nomoto_zoh_zigzag, in degrees)
ZOH_SPEC = SPEC.replace("speed: 3.0", "speed: 1.18")


def _zoh_log_frame(n: int) -> pd.DataFrame:
    d = nomoto_zoh_zigzag(n=n).data.copy()
    for c in ("psi", "r", "delta"):
        d[c] = np.degrees(d[c])
    return d


def test_names_every_gap_it_repairs(tmp_path):
    # commands/identify.py _load: prepare() filled 858 of 6000 NaN yaw-rate samples silently and
    # the estimator then warned about only the 2 it still saw; now the prepared trial counts
    # the 856 its grid bridged and the series the 2 at the record's ends (no extrapolation)
    d = _zoh_log_frame(6000)
    d.loc[::7, "r"] = np.nan
    log = tmp_path / "gaps.csv"
    d.to_csv(log, index=False, na_rep="")
    spec = tmp_path / "spec.yaml"
    spec.write_text(ZOH_SPEC)
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        code = main(["identify", str(log), "--format", str(spec), "--model", "nomoto1",
                     "--out", str(tmp_path / "m.json"), "--json"])
    assert code == 0
    msgs = [str(x.message) for x in w if issubclass(x.category, IdentificationWarning)]
    assert any("channel 'r' has 856 NaN samples; interpolated linearly" in m for m in msgs), msgs
    assert any("channel 'r' has 2 NaN/inf samples" in m for m in msgs), msgs


def test_identify_model_file_schema_and_exit_2(tmp_path, capsys):
    # ARCHITECTURE.md model-file schema, loadable by `usvid simulate`; a constant rudder is
    # exit 2 with a one-line reason.
    d = _zoh_log_frame(4000)
    log = tmp_path / "z.csv"
    d.to_csv(log, index=False)
    spec = tmp_path / "spec.yaml"
    spec.write_text(ZOH_SPEC)
    out = tmp_path / "m.json"
    assert main(["identify", str(log), "--format", str(spec), "--model", "nomoto1",
                 "--method", "ls", "--out", str(out), "--json"]) == 0
    m = json.loads(out.read_text())
    assert m["usvid_model"] == 1 and m["kind"] == "nomoto1"
    assert set(m["parameters"]) == {"K", "T", "delta0", "N_delta"}  # N_delta: null
    assert {"kind", "max_angle_deg"} <= set(m["servo"])
    assert m["vessel"] == {"length": 7.0, "speed": 1.18}
    ident = m["identification"]
    assert ident["data"] == [str(log)] and len(ident["data_sha256"][str(log)]) == 64
    assert ident["method"] == "ls" and set(ident["std_errors"]) == {"K", "T", "delta0"}
    assert "r" in ident["fit"]
    capsys.readouterr()
    assert main(["simulate", "zigzag", str(out), "--delta-deg", "10", "--psi-deg", "10",
                 "--json"]) == 0
    d["delta"] = 5.0
    d.to_csv(log, index=False)
    assert main(["identify", str(log), "--format", str(spec), "--model", "nomoto1",
                 "--out", str(tmp_path / "c.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert "no excitation" in err and "\n" not in err
    assert not (tmp_path / "c.json").exists()
