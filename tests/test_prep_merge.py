"""Merging the logs of several loggers of one run onto one clock."""

import numpy as np
import pandas as pd
import pytest

from usvid import Trial, UsvidError
from usvid.prep import merge_trials


def test_merge_puts_logs_on_one_clock_and_counts_repeats():
    # NMEA 0183 log starting 2 s after the epoch, candump log starting at it, a CSV in seconds
    # from the epoch (no t0_utc of its own)
    a = Trial(pd.DataFrame({"t": [0.0, 0.1, 0.2], "psi": [0.0, 0.01, 0.02]}), name="a",
              meta={"t0_utc": "2026-01-01T00:00:02+00:00"}, rejected={"checksum": 2})
    b = Trial(pd.DataFrame({"t": [2.0, 2.1, 2.1], "n": [10.0, 10.5, 11.0]}), name="b",
              meta={"t0_utc": "2026-01-01T00:00:00+00:00"})
    c = Trial(pd.DataFrame({"t": [2.05, 2.1], "psi": [9.0, 9.0], "u": [5.0, 5.1]}), name="c")
    m = merge_trials([a, b, c], t0_utc="2026-01-01T00:00:00+00:00")
    # a's 0.0, 0.1, 0.2 become 2.0, 2.1, 2.2 and share rows with b's samples at 2.0 and 2.1
    assert m.t.tolist() == pytest.approx([2.0, 2.05, 2.1, 2.2])
    assert m["psi"][[0, 2, 3]] == pytest.approx([0.0, 0.01, 0.02])  # a's psi, not c's
    assert np.isnan(m["psi"][1])
    assert m["n"][[0, 2]] == pytest.approx([10.0, 10.5]) and np.isnan(m["n"][3])
    assert m["u"][[1, 2]] == pytest.approx([5.0, 5.1])
    # b's second sample at 2.1 s is counted, not silently dropped; a's rejects carried over
    assert m.rejected == {"checksum": 2, "duplicate_time": 1}
    assert [f.code for f in m.findings] == ["channel_in_several_logs"]
    assert m.meta["t0_utc"].startswith("2026-01-01T00:00:00")


def test_merge_needs_trials():
    with pytest.raises(UsvidError, match="no trials"):
        merge_trials([])


def test_merge_trials_mixed_naive_and_utc_epochs() -> None:
    # NMEA readers give "+00:00" epochs, the Excel reader a naive date-time: before the fix the
    # comparison raised pandas' TypeError (tz-naive vs tz-aware). Naive is taken as UTC.
    a = Trial(data=pd.DataFrame({"t": [0.0, 1.0, 2.0], "psi": [0.0, 0.1, 0.2]}), name="a",
              meta={"t0_utc": "2025-01-01T00:00:00+00:00"})
    b = Trial(data=pd.DataFrame({"t": [0.0, 1.0, 2.0], "delta": [0.0, 0.1, 0.2]}), name="b",
              meta={"t0_utc": "2025-01-01T00:00:01"})
    m = merge_trials([a, b])
    assert list(m.t) == [0.0, 1.0, 2.0, 3.0]
    assert list(m.data["delta"].iloc[1:]) == [0.0, 0.1, 0.2]  # b shifted by +1 s
    with pytest.raises(UsvidError, match="t0_utc"):
        merge_trials([a, b], t0_utc="garbage")
