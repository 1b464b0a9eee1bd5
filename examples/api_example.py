"""usvid from Python: the same chain as ``usvid demo``, step by step (about 20 s).

Run: ``.venv/bin/python examples/api_example.py [OUT_DIR]``.

1. generate a (quick) virtual Lanxin sea-trial campaign as NMEA 0183 / candump / CSV logs;
2. read one zig-zag back from its logs, audit it and put it on a uniform 50 Hz grid;
3. identify a first-order Nomoto model (output error) with 95 % intervals;
4. export it to a python-control transfer function (with the servo and its dead time);
5. simulate a 20/20 zig-zag on the identified model and check the IMO criterion;
6. regenerate an HTML report from the demo's run folder, if one is given.
"""

from __future__ import annotations

import sys
import tempfile
import warnings
from pathlib import Path

import control

from usvid.demo.campaign import generate_campaign, read_campaign_trial
from usvid.identify.estimator import identify
from usvid.manoeuvres.imo import imo_zigzag_check
from usvid.models.export import to_transfer_function
from usvid.prep import audit, prepare
from usvid.sim import run_zigzag


def main(out: Path) -> None:
    warnings.simplefilter("ignore")  # per-sample interpolation notices of the multi-rate logs
    # 1. virtual campaign (seeded: the same seed gives byte-identical logs)
    camp = generate_campaign(out / "logs", seed=1, quick=True)
    zz = next(ct for ct in camp.trials if ct.manoeuvre.name == "zigzag_10_10")
    print("log files:", ", ".join(Path(f).name for f in zz.files.values()))

    # 2. read back through usvid.io, audit, prepare
    raw = read_campaign_trial(zz)
    for finding in audit(raw):
        print(f"audit [{finding.severity}] {finding.code}: {finding.message[:70]}")
    trial = prepare(raw, rate_hz=50.0)

    # 3. identify: T r' + r = K delta (Mu et al. 2018, eq. 38); the servo (2nd order with
    # dead time) is identified from the commanded and actual rudder of the same log
    nomoto = identify([trial], "nomoto1", "oe")
    for name in ("K", "T"):
        lo, hi = nomoto.ci95[name]
        print(f"{name} = {nomoto.params[name]:.4f}  95 % [{lo:.4f}, {hi:.4f}]  "
              f"truth {camp.truth['nomoto1'][name]:.4f}")

    # 4. python-control: r/delta, and psi/delta_cmd with the identified servo (Pade dead time)
    model = nomoto.model
    print("r/delta =", to_transfer_function(model))
    heading = to_transfer_function(model, output="psi", include_servo=True, pade_order=2)
    print("poles of psi/delta_cmd:", control.poles(heading).round(3))

    # 5. simulate a 20/20 zig-zag and judge it (IMO MSC.137(76), 20/20 first overshoot)
    _, zm = run_zigzag(model, 20.0, 20.0, t_end=60.0, u0=camp.vessel["speed"])
    check = imo_zigzag_check(zm, camp.vessel["length"], camp.vessel["speed"], "20/20")
    print(f"20/20 overshoots {zm.overshoot_deg[:2]} deg; IMO passed: {check.passed}")

    # 6. a demo run folder (usvid demo --out DIR) -> report.html
    if len(sys.argv) > 2:
        from usvid.report.run import regenerate

        print("report:", regenerate(sys.argv[2]))


if __name__ == "__main__":
    if len(sys.argv) > 1:
        main(Path(sys.argv[1]))
    else:
        with tempfile.TemporaryDirectory() as tmp:
            main(Path(tmp))
