"""The Trial container."""

import numpy as np
import pandas as pd
import pytest

from usvid import Trial, UsvidError


def test_trial_access_and_rate():
    t = np.arange(0, 1.0, 0.05)
    tr = Trial(pd.DataFrame({"t": t, "psi": np.sin(t)}), name="x")
    assert tr.sample_rate == pytest.approx(20.0)
    assert tr.has("psi") and not tr.has("r")
    with pytest.raises(UsvidError, match="channel 'r' is absent"):
        tr["r"]
    part = tr.slice_time(0.2, 0.5)
    assert part.t[0] == pytest.approx(0.2) and part.t[-1] == pytest.approx(0.5)


def test_trial_needs_time():
    with pytest.raises(UsvidError):
        Trial(pd.DataFrame({"psi": [0.0]}))
