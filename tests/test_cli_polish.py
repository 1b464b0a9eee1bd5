"""User-facing polish: --version, python -m usvid, shipped examples, one-line warnings, the
matplotlib backend left alone, HTML representations for Jupyter."""

from __future__ import annotations

import json
import subprocess
import sys
import warnings

import pytest

from usvid import __version__
from usvid.cli import _one_line_warning, main


def test_version_flag_and_python_m(capsys):
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"usvid {__version__}"
    out = subprocess.run([sys.executable, "-m", "usvid", "--version"], capture_output=True,
                         text=True, timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == f"usvid {__version__}"


def test_example_is_copied_and_loads(tmp_path, capsys):
    from usvid.io.modelfile import load_model

    assert main(["example", "lanxin_norrbin", "--out", str(tmp_path), "--json"]) == 0
    path = json.loads(capsys.readouterr().out)["file"]
    assert load_model(path).dynamics.K > 0
    # never over an existing file; an unknown name lists the shipped ones
    assert main(["example", "lanxin_norrbin", "--out", str(tmp_path)]) == 2
    assert "exists already" in capsys.readouterr().err
    assert main(["example", "kvlcc2", "--out", str(tmp_path)]) == 2
    assert "lanxin_threedof" in capsys.readouterr().err


def test_warnings_are_one_line():
    text = _one_line_warning(UserWarning("trial a: resampled\n  to 10 Hz"), UserWarning,
                             "/x/y.py", 12, "code()")
    assert text == "usvid: warning: trial a: resampled to 10 Hz\n"


def test_importing_usvid_keeps_the_matplotlib_backend():
    code = ("import matplotlib; matplotlib.use('pdf'); import usvid, usvid.report.figures, "
            "usvid.report.run; print(matplotlib.get_backend())")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "pdf"


def test_results_have_html_reprs():
    from usvid.manoeuvres.metrics import TurningMetrics, ZigZagMetrics

    z = ZigZagMetrics([12.5, 13.0], 15.9, 3.9, 2.4)._repr_html_()
    assert "<table>" in z and "overshoot_deg" in z and "12.5, 13" in z
    t = TurningMetrics(25.0, 12.6, 24.5, 23.8, 0.43, 5.1)._repr_html_()
    assert "tactical_diameter_m" in t


@pytest.mark.parametrize("kind", ["nomoto1"])
def test_identified_model_html(kind):
    import numpy as np

    from usvid.identify.estimator import IdentifiedModel

    m = IdentifiedModel(kind, "ls", {"K": 0.5, "T": 3.0}, {"K": 0.01, "T": 0.1},
                        {"K": [0.48, 0.52], "T": [2.8, 3.2]}, np.eye(2), {}, None)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        h = m._repr_html_()
    assert "<code>K</code>" in h and "0.48 .. 0.52" in h
