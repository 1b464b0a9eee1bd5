"""The part of a log where every channel a model needs is logged (usvid.identify.span): sensors
that start late are cut off with a warning naming the part and the channels."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from usvid.identify.series import IdentificationWarning
from usvid.identify.span import MIN_CUT_S, kind_channels, logged_span, trim_to_logged
from usvid.models.registry import get as get_kind
from usvid.trial import Trial


def _trial(start_u: float, stop_n: float | None = None) -> Trial:
    """20 s at 10 Hz; u from ``start_u`` s on (an INS that starts late), n_port until
    ``stop_n``."""
    t = np.arange(0.0, 20.0 + 1e-9, 0.1)
    u = np.where(t >= start_u, 1.0, np.nan)
    n = np.ones_like(t) if stop_n is None else np.where(t <= stop_n, 1.0, np.nan)
    return Trial(pd.DataFrame({"t": t, "psi": np.where(t >= start_u, 0.1, np.nan), "u": u,
                               "n_port": n, "n_stbd": np.ones_like(t)}), name="late")


def test_late_sensor_cut_with_the_part_said():
    tr = _trial(8.0, stop_n=18.0)
    assert logged_span(tr, ("psi", "u", "n_port", "n_stbd")) == (8.0, 18.0, ["n_port", "psi",
                                                                            "u"])
    with pytest.warns(IdentificationWarning, match=r"0\.0-8\.0 s and 18\.0-20\.0 s .*'u'"):
        cut = trim_to_logged(tr, ("psi", "u", "n_port", "n_stbd"))
    assert cut.t[0] == pytest.approx(8.0) and cut.t[-1] == pytest.approx(18.0)
    assert np.all(np.isfinite(cut["u"])) and len(cut) == 101


def test_whole_log_and_short_gaps_untouched():
    tr = _trial(0.5 * MIN_CUT_S)  # a leading gap shorter than MIN_CUT_S: left to interpolation
    assert logged_span(tr, ("psi", "u")) is None
    assert trim_to_logged(tr, ("psi", "u")) is tr
    # a channel the kind does not read does not cut the log
    assert logged_span(_trial(8.0), ("n_port", "n_stbd")) is None
    # a channel missing for most of the log is not cut to its rest (the series refuse it)
    assert logged_span(_trial(12.0), ("psi", "u")) is None


def test_kind_channels_of_the_catamaran():
    assert set(kind_channels(get_kind("catamaran"))) >= {"psi", "u", "v", "r", "n_port",
                                                        "n_stbd"}


def test_astern_under_thrust_ahead_found_by_hand():
    """u below -0.15 m/s for 1.5 s while both thrusters push ahead: one stretch, from 5.0 to
    6.5 s, u down to -0.4; astern under thrust astern (a reversing boat) is none; a stretch
    of 0.5 s (shorter than MIN_ASTERN_S) is none."""
    from usvid.identify.thrust_consistency import astern_under_thrust_ahead, describe

    t = np.arange(0.0, 10.0 + 1e-9, 0.1)
    u = np.where((t >= 5.0) & (t <= 6.5), -0.4, 0.8)
    u = np.where((t >= 2.0) & (t <= 2.5), -0.4, u)
    tp = np.full_like(t, 10.0)
    ts = np.where(t < 7.0, 10.0, -10.0)
    tr = Trial(pd.DataFrame({"t": t, "u": u, "n_port": tp, "n_stbd": ts}), name="x")
    bad = astern_under_thrust_ahead(tr, lambda c: c)
    assert bad == [pytest.approx((5.0, 6.5, -0.4))]
    assert describe(bad) == "5.0-6.5 s (u down to -0.40 m/s)"
    # the same log driven astern by both thrusters: consistent
    back = Trial(pd.DataFrame({"t": t, "u": u, "n_port": -tp, "n_stbd": -tp}), name="y")
    assert astern_under_thrust_ahead(back, lambda c: c) == []
