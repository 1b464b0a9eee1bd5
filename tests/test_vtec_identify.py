"""``usvid identify --model catamaran`` and ``usvid validate`` on the real VTec S3 bags (skipped
when the data folder is absent): the command line a user types exits 0 with a model that passes
its physical checks, or exits 2 with a specific reason (never a traceback, never a model with a
surge mass of 1e7 kg); a written model replays a held-out run with its heading and track RMS.
Two short zig-zag runs, so that the test stays fast (the split of the README's table: the five
zig-zag runs train, the other good runs are held out)."""

from __future__ import annotations

import json

import pytest

from usvid.cli import main

TRAIN = ("mpc_pf_exp2__zz_2021-07-08-14-17-07.bag", "mpc_pf_exp2__zz_2021-07-08-14-21-12.bag")
HELD_OUT = "mpc_guidance_exp0__vn_2021-06-08-15-15-20.bag"


@pytest.fixture(scope="module")
def identified(vtec_dir, tmp_path_factory):
    """The default identification (exit code, JSON or message), then the same with
    --accept-failed-checks (a model file to validate whatever the checks said)."""
    out = tmp_path_factory.mktemp("vtec") / "cat.json"
    logs = [str(vtec_dir / n) for n in TRAIN]
    return logs, out


def test_identify_catamaran_is_physical_or_refused(identified, capsys):
    logs, out = identified
    code = main(["identify", *logs, "--format", "vtec_usv", "--model", "catamaran",
                 "--out", str(out), "--json"])
    cap = capsys.readouterr()
    assert code in (0, 2), cap.err
    assert "Traceback" not in cap.err
    if code == 0:
        s = json.loads(cap.out)
        m = s["params"]
        # the vessel: 30 kg, 4.1 kg m^2 (the spec); the checks hold the masses to a hull's
        assert 0.8 * 30 <= m["m11"] <= 2 * 30 and 0.8 * 30 <= m["m22"] <= 4 * 30
        assert 0.5 * 4.1 <= m["m33"] <= 5 * 4.1
        assert all(v > 0 for k, v in m.items() if k.startswith("d"))
        model = json.loads(out.read_text())
        assert all(c["passed"] for c in model["identification"]["checks"])
    else:
        # a specific reason: which check or parameter, with its value
        err = cap.err.split("usvid: error:")[-1]
        assert "fails its checks" in err or "not a valid model" in err or "identif" in err
        assert any(k in err for k in ("m11", "m22", "m33", "R^2", "diverges", "d11", "d33")), err
        assert not out.exists()


def test_validate_prints_heading_and_track_rms(identified, vtec_dir, capsys, tmp_path):
    logs, _ = identified
    out = tmp_path / "cat_any.json"
    code = main(["identify", *logs, "--format", "vtec_usv", "--model", "catamaran",
                 "--accept-failed-checks", "--out", str(out)])
    assert code == 0 and out.exists()
    capsys.readouterr()
    code = main(["validate", str(out), str(vtec_dir / HELD_OUT), "--format", "vtec_usv",
                 "--json"])
    cap = capsys.readouterr()
    assert code == 0, cap.err
    row = json.loads(cap.out)["validation"][0]
    rep = row["replay"]
    assert rep["psi_rms_deg"] >= 0 and rep["track_rms_m"] >= 0
    # the INS starts 8 s into the bag: the replay says which part it used
    assert any("not logged" in m for m in row["messages"])
    code = main(["validate", str(out), str(vtec_dir / HELD_OUT), "--format", "vtec_usv"])
    text = capsys.readouterr().out
    assert code == 0 and "psi_rms_deg" in text and "track_rms_m" in text
