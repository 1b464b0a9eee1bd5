"""``usvid validate --report`` succeeds on every log where ``usvid validate`` succeeds: the demo
campaign's NMEA 0183, NMEA 2000 and CSV logs, an HSVA zig-zag, a twin-thruster log and the real
logs of ``../shared/data/real_logs`` that validate accepts.

It exited 2 on the demo's NMEA logs ("channel 'delta' has 13198 of 19199 samples NaN/inf" after
"time grid not uniform; resampled linearly to 460 Hz"): the report's prediction band built the
series of the raw multi-rate log a second time, on its own grid. Now the command prepares each log
once and the validation and the report use that prepared trial.

Each log is validated in process as the command does it (:func:`validate_logs`); when validate
accepts it, the report (:func:`write_validation_report`) must be written. The demo campaign's logs
are checked in ``tests/test_campaign.py`` (which generates them once).
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from conftest import SHARED_DATA
from usvid.commands.validate import validate_logs
from usvid.errors import UsvidError
from usvid.io.modelfile import save_model
from usvid.models import IdealServo, Nomoto1, VesselModel
from usvid.report.validation_run import write_validation_report
from usvid.trial import Vessel

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
REAL = SHARED_DATA / "real_logs"


def validate_and_report(model: Path, log: str, fmt: str, out: Path) -> bool:
    """False when validate refuses the log; else writes the report (an error fails the test)."""
    try:
        res, (vres, trials, vm) = validate_logs(model, [log], fmt)
    except UsvidError:
        return False
    assert res["validation"][0]["trial"]
    path = write_validation_report(out, vres, trials, model=vm, model_path=model)
    assert path.is_file() and (out / "run.json").is_file()
    return True


def test_hsva_log(hsva_dir, tmp_path):
    model = save_model(VesselModel(Nomoto1(K=0.25, T=16.0), IdealServo(max_rate=math.radians(
        15.8)), Vessel(length=7.0, speed=1.18)), tmp_path / "kv.json")
    assert validate_and_report(model, str(hsva_dir / "HSVA_CPMC_KVLCC2_Z_10_10_S.dat"),
                                "hsva_kvlcc2", tmp_path / "rep")


def test_twin_thruster_log(twin_dir, tmp_path):
    assert validate_and_report(EXAMPLES / "usv_twin_mmg.json",
                                f"{twin_dir / 'boat1_2_circle.xlsx'}:0:30", "twin_thruster_xlsx",
                                tmp_path / "rep")


def test_real_logs(tmp_path):
    if not REAL.is_dir():
        pytest.skip(f"real logs not found at {REAL} (../shared/data is not beside the repo)")
    accepted = []
    for log in sorted(REAL.iterdir()):
        if log.suffix in (".md", ".parm"):
            continue
        if validate_and_report(EXAMPLES / "lanxin.json", str(log), "auto",
                                tmp_path / log.stem):
            accepted.append(log.name)
    # the logs validate reads (and replays where they hold a rudder): every one got its report
    assert len(accepted) >= 5, accepted
