"""The readers' frame construction (io._assemble.channel_frame) gives what
``pd.DataFrame(dict)`` gives: the same labels Index (dtype included), index, one float64 block,
the values bit for bit; its kept labels Index is not shared by the frames' own ``columns``."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from usvid.io._assemble import channel_frame


@pytest.mark.parametrize("cols", [
    {"t": np.array([0.0, 0.5, 1.0]), "psi": np.array([np.nan, -0.0, 1e308]),
     "r": np.array([np.inf, 2.0, -np.inf])},
    {"t": np.array([3.0])},
    {"t": np.arange(5.0), "x": np.arange(5.0) * 2, "é☃": np.ones(5)},
])
def test_same_frame_as_pandas(cols):
    want = pd.DataFrame(cols)
    got = channel_frame(cols)
    pd.testing.assert_frame_equal(got, want, check_exact=True, check_column_type=True,
                                  check_index_type=True)
    assert got.columns.dtype == want.columns.dtype
    assert got._mgr.nblocks == want._mgr.nblocks == 1
    for c in cols:
        assert got[c].to_numpy().tobytes() == want[c].to_numpy().tobytes()
    # each frame has its own labels Index: naming one does not name another
    again = channel_frame(cols)
    got.columns.name = "renamed"
    assert again.columns.name is None and channel_frame(cols).columns.name is None
    # and its own values
    got.iloc[0, 0] = 99.0
    assert again.iloc[0, 0] == want.iloc[0, 0]


@pytest.mark.parametrize("cols", [
    {"t": np.array([0.0, 1.0]), 3: np.array([1.0, 2.0])},  # a label that is not a str
    {"t": np.array([0, 1])},  # integers
    {"t": np.array([0.0, 1.0]), "x": np.array([1.0])},  # lengths differ: pandas raises
])
def test_anything_else_is_pandas(cols):
    try:
        want = pd.DataFrame(cols)
    except ValueError as exc:
        with pytest.raises(ValueError, match=str(exc)[:20]):
            channel_frame(cols)
        return
    pd.testing.assert_frame_equal(channel_frame(cols), want, check_exact=True)
