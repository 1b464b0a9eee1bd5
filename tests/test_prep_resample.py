"""usvid.prep.resample: multi-rate alignment on one uniform grid, no extrapolation across gaps."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from usvid.errors import UsvidError
from usvid.prep import prepare
from usvid.prep.resample import infer_rate, interp_channel, resample, stream_rate
from usvid.trial import Trial


def _union_trial() -> Trial:
    """Heading at 10 Hz, a 1 Hz 'U' with a 5-s hole, stamped as the union of both clocks."""
    t_fast = np.round(np.arange(0, 20.0001, 0.1), 10)
    t_slow = np.arange(0.05, 20, 1.0)
    t_slow = t_slow[(t_slow < 8) | (t_slow > 13)]  # a 6-s hole
    t = np.union1d(t_fast, t_slow)
    psi = np.where(np.isin(t, t_fast), 0.01 * t, np.nan)
    U = np.where(np.isin(t, t_slow), 1.0 + 0.1 * t, np.nan)
    return Trial(pd.DataFrame({"t": t, "psi": psi, "U": U}), name="union")


def test_union_of_timestamps_to_uniform_grid():
    tr = _union_trial()
    assert not tr.is_uniform
    assert infer_rate(tr) == pytest.approx(10.0)  # the fastest channel
    out = resample(tr)
    assert out.sample_rate == pytest.approx(10.0)
    t = out.t
    np.testing.assert_allclose(out["psi"], 0.01 * t, atol=1e-12)  # linear: exact
    U = out["U"]
    inside = (t >= 0.05) & (t <= 19.05) & ~((t > 7.05) & (t < 13.05))
    np.testing.assert_allclose(U[inside], 1.0 + 0.1 * t[inside], atol=1e-12)
    # before the first 1-Hz sample and after the last: not extrapolated
    assert np.isnan(U[t < 0.05]).all() and np.isnan(U[t > 19.05 + 1e-9]).all()
    # the 6-s hole is longer than max(1 s, 5 x 1 s) -> missing and reported
    assert np.isnan(U[(t > 7.1) & (t < 13.0)]).all()
    f = [f for f in out.findings if f.code == "resample_gap" and f.channel == "U"]
    assert f and f[0].count > 50
    assert out.meta["resample"]["nan_counts"]["psi"] == 0


def test_max_gap_bridges_when_allowed():
    out = resample(_union_trial(), 10.0, max_gap_s=10.0)
    t = out.t
    sel = (t > 7.1) & (t < 13.0)
    np.testing.assert_allclose(out["U"][sel], 1.0 + 0.1 * t[sel], atol=1e-12)


def test_angles_interpolate_through_the_wrap():
    # 170 deg then -170 deg one second later: half-way is 180 deg, not 0
    t = np.array([0.0, 1.0])
    psi = np.deg2rad([170.0, -170.0])
    v = interp_channel(t, psi, np.array([0.0, 0.5, 1.0]), max_gap_s=5.0, angle=True)
    np.testing.assert_allclose(np.rad2deg(v), [170.0, 180.0, 190.0])
    lin = interp_channel(t, psi, np.array([0.5]), max_gap_s=5.0, angle=False)
    assert abs(lin[0]) < 1e-12  # what naive interpolation would do


def test_resample_downsamples_and_rejects_bad_rate():
    t = np.arange(0, 10.0001, 0.02)
    tr = Trial(pd.DataFrame({"t": t, "r": np.sin(t)}))
    out = resample(tr, 5.0)
    assert len(out) == 51
    np.testing.assert_allclose(out["r"], np.sin(out.t), atol=1e-3)  # linear interp at 50 Hz
    with pytest.raises(UsvidError, match="rate"):
        resample(tr, 0.0)
    with pytest.raises(UsvidError, match="fewer than two"):
        resample(Trial(pd.DataFrame({"t": [0.0], "r": [1.0]})))


# --- the rate of a channel: its message stream ------------------------------------------------
def _bursty(rate_hz: float = 10.0, burst_s: float = 0.5, seconds: float = 60.0) -> Trial:
    """A gateway that stamps the frames of a ``rate_hz`` heading stream in bursts: every
    ``burst_s`` the frames of the last ``burst_s`` arrive within a few milliseconds (the
    records' median spacing is 1 ms, the stream's rate ``rate_hz``)."""
    k = np.arange(int(seconds * rate_hz))
    t_true = k / rate_hz
    per = int(round(burst_s * rate_hz))
    t = np.floor(t_true / burst_s) * burst_s + burst_s + 0.001 * (k % per)
    return Trial(pd.DataFrame({"t": t, "psi": 0.01 * t_true}), name="burst")


def test_stream_rate_of_bursty_regular_jittered_and_gappy_streams():
    tr = _bursty()
    assert np.median(np.diff(tr.t)) == pytest.approx(0.001)  # what the median saw: 1 kHz
    # bursty: 599 spacings from the first stamp (0.5 s) to the last (60.004 s; every spacing,
    # the 0.496 s between bursts included, flows): 599 / 59.504 s
    assert stream_rate(tr.t, tr["psi"]) == pytest.approx(599 / 59.504, rel=1e-9)
    assert infer_rate(tr) == pytest.approx(10.07, abs=0.01)
    # regular with every tenth sample dropped: the nominal 10 Hz (the log keeps its samples
    # on the grid), not the 9 Hz of the samples over the time
    t = np.arange(0.0, 60.0, 0.1)
    keep = np.arange(len(t)) % 10 != 5
    assert stream_rate(t[keep], t[keep]) == pytest.approx(10.0, rel=1e-9)
    # jitter of +-20 ms on 10 Hz stamps (seeded): within 5 % of 10 Hz (the median of 600
    # jittered spacings)
    rng = np.random.default_rng(0)
    tj = t + rng.uniform(-0.02, 0.02, len(t))
    assert stream_rate(tj, tj) == pytest.approx(10.0, rel=0.05)
    # a 20-s hole in a 10 Hz stream is not part of its rate
    hole = (t < 20.0) | (t >= 40.0)
    assert stream_rate(t[hole], t[hole]) == pytest.approx(10.0, rel=1e-9)
    assert stream_rate(np.array([1.0]), np.array([1.0])) is None


def test_a_bursty_log_is_prepared_on_the_streams_grid():
    p = prepare(_bursty(), derivatives=False)
    assert p.sample_rate == pytest.approx(10.07, abs=0.01)  # was 1000 Hz (the median spacing)
    assert len(p) == pytest.approx(60 * 10.07, abs=15)


def test_the_real_bursty_gateway_log_gets_a_sane_grid(real_logs_dir):
    """canboat_dirona-actisense-serial.raw: NMEA 2000 frames stamped in bursts (median record
    spacing 2 ms); the fastest stream, the heading (1,402 frames in 64.5 s, mostly in pairs 2 ms
    apart), flows at 21.7 Hz. The one road (prepare, so metrics and identify) used a 500 Hz
    grid."""
    from usvid.prep.logs import read_log

    tr = read_log(real_logs_dir / "canboat_dirona-actisense-serial.raw", "auto")
    p = prepare(tr, derivatives=False)
    assert p.sample_rate == pytest.approx(21.72, abs=0.01)  # as measured
    assert p.sample_rate <= 50.0 and len(p) < 1500  # 64.5 s of log
