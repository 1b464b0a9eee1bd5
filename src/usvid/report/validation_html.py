"""The HTML report of an identification or validation run (``run_kind`` "validation", written
by :mod:`usvid.report.validation_run`): one self-contained file that works offline.

Sections: the model (equation, parameters with standard errors and 95 % intervals, correlation
matrix of the estimates, the disturbance estimated per training log when there is one: the
current as an arrow with its speed and direction, each component and bias with its 95 %
interval, the separability warning), then the **training** trials and the **held-out** trials in
separate sections (a model judged on the data it was fitted to says little about its
prediction). Per trial: measured vs predicted manoeuvre metrics with labels and units, the IMO
MSC.137(76) criteria with their applicability (the Standards apply to ships of 100 m in length
and over), and interactive figures (plotly, its JavaScript embedded once, no network): measured
heading and yaw rate against the free-run replay with its 95 % prediction band, the residuals,
the track (axes scaled independently so a long run is not squashed) and the predicted manoeuvre
against the measured one. A held-out run predicted in its own conditions (its logged wind, the
current estimated from its approach) shows them: the wind speed and direction over the
manoeuvre, the current as an arrow with its numbers (or why there is none), and that prediction
beside the calm-water one in the table and the manoeuvre figure. Print CSS keeps each heading
with its figure.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import plotly.graph_objects as go
import plotly.offline

from usvid.manoeuvres.imo import imo_turning_check, imo_zigzag_check
from usvid.report.html import CSS, _table, esc, fmt

#: Length [m] from which IMO MSC.137(76) applies (its section 1.2: ships of 100 m and over).
IMO_MIN_LENGTH_M = 100.0

#: Readable labels and units of the metric keys (those of ``usvid metrics``).
LABELS: dict[str, tuple[str, str]] = {
    "overshoot_deg": ("overshoot angles (first first)", "deg"),
    "period_s": ("period", "s"),
    "initial_turning_time_s": ("initial turning time", "s"),
    "time_to_check_yaw_s": ("time to check yaw", "s"),
    "advance_m": ("advance", "m"),
    "transfer_m": ("transfer", "m"),
    "tactical_diameter_m": ("tactical diameter", "m"),
    "steady_diameter_m": ("steady turning diameter", "m"),
    "steady_yaw_rate_rad_s": ("steady yaw rate", "rad/s"),
    "steady_speed_m_s": ("steady speed", "m/s"),
    "psi_rms_deg": ("heading error, RMS", "deg"),
    "r_rms_deg_s": ("yaw-rate error, RMS", "deg/s"),
    "u_rms_m_s": ("surge-speed error, RMS", "m/s"),
    "track_rms_m": ("track error, RMS", "m"),
    "track_max_m": ("track error, largest", "m"),
    "duration_s": ("replayed duration", "s"),
    "diverged_at_s": ("free run diverged after", "s"),
    "wind": ("replayed in", ""),
}

PRINT_CSS = """
@media print {
  h2, h3 { break-after: avoid; page-break-after: avoid; }
  .trial { break-inside: avoid-page; }
  .plotly-graph-div { break-inside: avoid; }
  h2 { break-before: auto; }
}
.band { color: #1565c0; }
"""

_CONFIG = {"displaylogo": False, "responsive": True,
           "toImageButtonOptions": {"format": "svg"}}


def _plot(fig: go.Figure, div_id: str) -> str:
    fig.update_layout(margin={"l": 60, "r": 20, "t": 40, "b": 45}, template="plotly_white",
                      legend={"orientation": "h", "y": -0.2})
    return fig.to_html(full_html=False, include_plotlyjs=False, config=_CONFIG, div_id=div_id)


def _deg(a: Sequence[Any] | None) -> list[float | None]:
    return [None if v is None else math.degrees(v) for v in (a or [])]


def _timeseries(e: Mapping[str, Any], idx: str) -> str:
    s, b = e.get("series", {}), e.get("band", {})
    if "t" not in s or "psi_replay" not in s:
        return '<p class="na">no replay of this trial</p>'
    t = s["t"]
    out = []
    for ch, label, unit in (("psi", "heading", "deg"), ("r", "yaw rate", "deg/s")):
        fig = go.Figure()
        if f"{ch}_lo" in b:
            fig.add_trace(go.Scatter(x=b["t"], y=_deg(b[f"{ch}_hi"]), line={"width": 0},
                                     showlegend=False, hoverinfo="skip"))
            fig.add_trace(go.Scatter(x=b["t"], y=_deg(b[f"{ch}_lo"]), line={"width": 0},
                                     fill="tonexty", fillcolor="rgba(21,101,192,0.2)",
                                     name="95 % prediction band"))
        fig.add_trace(go.Scatter(x=t, y=_deg(s.get(ch)), name="measured",
                                 line={"color": "#222"}))
        fig.add_trace(go.Scatter(x=t, y=_deg(s.get(f"{ch}_replay")), name="model (free run)",
                                 line={"color": "#1565c0"}))
        fig.update_layout(title=f"{label}: measured vs model", height=330,
                          xaxis_title="time [s]", yaxis_title=f"{label} [{unit}]")
        out.append(_plot(fig, f"{idx}-{ch}"))
    fig = go.Figure()
    for ch, label in (("psi", "heading [deg]"), ("r", "yaw rate [deg/s]")):
        m, r = s.get(ch) or [], s.get(f"{ch}_replay") or []
        res = [None if a is None or c is None else math.degrees(a - c)
               for a, c in zip(m, r, strict=False)]
        fig.add_trace(go.Scatter(x=t, y=res, name=f"residual {label}"))
    fig.update_layout(title="residuals (measured - model)", height=300, xaxis_title="time [s]",
                      yaxis_title="residual")
    out.append(_plot(fig, f"{idx}-res"))
    return "".join(out)


def _track(e: Mapping[str, Any], idx: str) -> str:
    s = e.get("series", {})
    if "x" not in s or "x_replay" not in s:
        return ""
    fig = go.Figure()
    fig.add_trace(go.Scatter(x=s["y"], y=s["x"], name="measured", line={"color": "#222"}))
    fig.add_trace(go.Scatter(x=s["y_replay"], y=s["x_replay"], name="model (free run)",
                             line={"color": "#1565c0"}))
    xs = [v for v in s["x"] + s["x_replay"] if v is not None]
    ys = [v for v in s["y"] + s["y_replay"] if v is not None]
    span_x = (max(xs) - min(xs)) if xs else 1.0
    span_y = (max(ys) - min(ys)) if ys else 1.0
    # equal aspect only when it does not squash the track (ratio of spans within 1:4)
    if span_x > 0 and span_y > 0 and 0.25 <= span_x / span_y <= 4:
        fig.update_yaxes(scaleanchor="x", scaleratio=1)
    fig.update_layout(title="track (north up)", height=420, xaxis_title="east y [m]",
                      yaxis_title="north x [m]")
    return _plot(fig, f"{idx}-xy")


def _manoeuvre_plot(e: Mapping[str, Any], idx: str) -> str:
    s, m = e.get("series", {}), e.get("measured", {})
    if "t_pred" not in s or "t" not in s or "t_execute" not in m:
        return ""
    side = 1 if m.get("first_side", "starboard") == "starboard" else -1
    te = m["t_execute"]
    t, psi = s["t"], s["psi"]
    k0 = min(range(len(t)), key=lambda i: abs(t[i] - te))
    dev = [None if p is None else math.degrees(side * (p - psi[k0])) for p in psi]
    tp, pp = s["t_pred"], s.get("psi_pred") or []
    dev_p = [None if p is None else math.degrees(side * (p - pp[0])) for p in pp]
    fig = go.Figure()
    fig.add_trace(go.Scatter(x=[v - te for v in t], y=dev, name="measured",
                             line={"color": "#222"}))
    fig.add_trace(go.Scatter(x=tp, y=dev_p, name="predicted (closed loop)",
                             line={"color": "#c62828", "dash": "dash"}))
    if "t_env" in s:
        pe = s.get("psi_env") or []
        fig.add_trace(go.Scatter(
            x=s["t_env"], y=[None if p is None else math.degrees(side * (p - pe[0]))
                             for p in pe],
            name="predicted in the run's conditions", line={"color": "#2e7d32", "dash": "dot"}))
    fig.update_layout(title=f"{e['manoeuvre']}: heading change from the execute", height=330,
                      xaxis_title="time from the execute [s]",
                      yaxis_title="heading change, first side positive [deg]")
    return _plot(fig, f"{idx}-man")


def _metric_table(e: Mapping[str, Any]) -> str:
    rows = []
    for k, err in e.get("error", {}).items():
        label, unit = LABELS.get(k, (k, ""))
        rows.append([esc(label), esc(unit), fmt(e["measured"].get(k)),
                     fmt(e["predicted"].get(k)), fmt(err)])
    if not rows:
        return '<p class="na">no manoeuvre metrics (no zig-zag or turning circle found)</p>'
    pc, ec = e.get("predicted_in_conditions"), e.get("error_in_conditions")
    if pc:
        for row, k in zip(rows, e.get("error", {}), strict=True):
            row.extend([fmt(pc.get(k)), fmt((ec or {}).get(k))])
        return _table(["metric", "unit", "measured", "predicted (calm water)",
                       "predicted - measured", "predicted (own conditions)",
                       "predicted - measured"], rows, 2)
    return _table(["metric", "unit", "measured", "predicted", "predicted - measured"], rows, 2)


def _conditions(e: Mapping[str, Any], idx: str) -> str:
    """The run's own conditions: a table (wind, current, or why missing), the logged wind over
    the manoeuvre and the current as an arrow (north up)."""
    c = e.get("conditions")
    if not c:
        return ""
    rows = []
    w, cur = c.get("wind"), c.get("current")
    if w:
        rows.append(["true wind", f"{fmt(w['speed_m_s']['mean'])} m/s mean "
                     f"({fmt(w['speed_m_s']['min'])} .. {fmt(w['speed_m_s']['max'])}), from "
                     f"{fmt(w['mean_direction_from_deg'])} deg", esc(w["source"])])
    if cur:
        rows.append(["current", f"{fmt(cur['speed_m_s'])} m/s towards "
                     f"{fmt(cur['direction_towards_deg'])} deg", esc(cur["method"])])
    notes = "".join(f'<p class="na">{esc(m)}</p>' for m in c.get("messages", []))
    out = "<h4>The run's own conditions</h4>" + (
        _table(["", "value", "from"], rows, 2) if rows else "") + notes
    s = e.get("series", {})
    if "t_wind" in s:
        fig = go.Figure()
        fig.add_trace(go.Scatter(x=s["t_wind"], y=s.get("speed_wind"), name="speed [m/s]",
                                 line={"color": "#1565c0"}))
        fig.add_trace(go.Scatter(x=s["t_wind"], y=_deg(s.get("dir_wind")), yaxis="y2",
                                 name="direction from [deg]", mode="markers",
                                 marker={"size": 3, "color": "#ef6c00"}))
        fig.update_layout(title="logged true wind over the manoeuvre", height=300,
                          xaxis_title="time from the execute [s]",
                          yaxis={"title": "speed [m/s]"},
                          yaxis2={"title": "from [deg]", "overlaying": "y", "side": "right",
                                  "range": [0, 360]})
        out += _plot(fig, f"{idx}-wind")
    if cur:
        d = math.radians(cur["direction_towards_deg"])
        sp = cur["speed_m_s"]
        fig = go.Figure()
        fig.add_annotation(x=sp * math.sin(d), y=sp * math.cos(d), ax=0, ay=0, xref="x",
                           yref="y", axref="x", ayref="y", showarrow=True, arrowhead=3,
                           arrowwidth=2, arrowcolor="#2e7d32",
                           text=f"{sp:.3g} m/s towards {cur['direction_towards_deg']:.0f} deg")
        lim = max(sp, 1e-3) * 1.4
        fig.update_xaxes(range=[-lim, lim], title="east [m/s]")
        fig.update_yaxes(range=[-lim, lim], title="north [m/s]", scaleanchor="x",
                         scaleratio=1)
        fig.update_layout(title="current (estimated from the approach)", height=320,
                          width=380)
        out += _plot(fig, f"{idx}-current")
    return out


def _replay_table(e: Mapping[str, Any]) -> str:
    rows = [[esc(LABELS.get(k, (k, ""))[0]), esc(LABELS.get(k, ("", ""))[1]), fmt(v)]
            for k, v in e.get("replay", {}).items()]
    w = e.get("replay_water")  # a model identified with a disturbance: the replay's water
    note = ""
    if w:
        where = ("the estimated current and biases" if w["water"] == "estimated"
                 else "calm water")
        note = f'<p class="na">replayed in {where}: {esc(w["why"])}</p>'
    return (_table(["free-run replay", "unit", "value"], rows, 2) + note) if rows else ""


def _imo(e: Mapping[str, Any], vessel: Mapping[str, Any]) -> str:
    L = vessel.get("length")
    sett = e.get("settings", {})
    U = sett.get("speed_m_s")
    if not L or e.get("manoeuvre") not in ("zigzag", "turning"):
        return ""
    applies = L >= IMO_MIN_LENGTH_M
    note = ("IMO MSC.137(76) applies (L = {:.1f} m >= 100 m)." if applies else
            "IMO MSC.137(76) does not apply (it covers ships of 100 m and over; L = {:.1f} m): "
            "the criteria are shown for reference only.").format(L)
    checks = []
    try:
        if e["manoeuvre"] == "zigzag":
            a, p = sett.get("delta_deg", 0.0), sett.get("psi_deg", 0.0)
            kind = next((f"{k}/{k}" for k in (10, 20)
                         if abs(a - k) <= 0.5 and abs(p - k) <= 0.5), None)
            if kind is None or not U:
                return f'<p class="na">{esc(note)} No IMO zig-zag criterion for a ' \
                       f'{a:.1f}/{p:.1f} test.</p>'
            for which in ("measured", "predicted"):
                checks.append((which, imo_zigzag_check(e[which], L, U, kind)))
        else:
            if abs(sett.get("delta_deg", 0.0)) < 34.5:
                return (f'<p class="na">{esc(note)} The turning criteria judge a circle at the '
                        'largest rudder angle (35 deg); this one is not.</p>')
            for which in ("measured", "predicted"):
                checks.append((which, imo_turning_check(e[which], L)))
    except Exception as exc:  # noqa: BLE001 - a report shows what it cannot judge
        return f'<p class="na">IMO criteria not evaluated: {esc(exc)}</p>'
    rows = []
    for which, c in checks:
        for cr in c.criteria:
            ok = {True: '<span class="ok">pass</span>', False: '<span class="bad">fail</span>',
                  None: '<span class="na">unknown</span>'}[cr.passed]
            rows.append([esc(which), esc(cr.name.replace("_", " ")), fmt(cr.value),
                         fmt(cr.limit), esc(cr.unit), ok])
    return (f"<p>{esc(note)}</p>" + _table(["", "criterion", "value", "limit", "unit", "verdict"],
                                           rows, 2))


def _trials(entries: Sequence[Mapping[str, Any]], vessel: Mapping[str, Any], prefix: str
            ) -> str:
    if not entries:
        return '<p class="na">none in this run</p>'
    out = []
    for i, e in enumerate(entries):
        idx = f"{prefix}{i}"
        sett = e.get("settings", {})
        desc = esc(e["manoeuvre"])
        if e["manoeuvre"] == "zigzag" and "psi_deg" in sett:
            desc = f"zig-zag {sett['delta_deg']:.1f}/{sett['psi_deg']:.1f} deg"
        elif e["manoeuvre"] == "turning" and "delta_deg" in sett:
            desc = f"turning circle, rudder {sett['delta_deg']:.1f} deg"
        notes = "".join(f'<p class="na">{esc(m)}</p>' for m in e.get("messages", []))
        out.append(
            f'<div class="trial"><h3 id="{idx}">{esc(e["trial"])}: {desc}</h3>{notes}'
            f"{_metric_table(e)}{_conditions(e, idx)}{_imo(e, vessel)}"
            f"{_manoeuvre_plot(e, idx)}"
            f"{_replay_table(e)}{_timeseries(e, idx)}{_track(e, idx)}</div>")
    return "".join(out)


def _model(model: Mapping[str, Any]) -> str:
    rows = []
    for k, v in model.get("params", {}).items():
        lo, hi = (model.get("ci95", {}).get(k) or [None, None])[:2]
        rows.append([f"<code>{esc(k)}</code>", esc(model.get("units", {}).get(k, "")), fmt(v),
                     fmt(model.get("std_errors", {}).get(k)), fmt(lo), fmt(hi)])
    head = (f"<p>kind <code>{esc(model.get('kind'))}</code>: {esc(model.get('equation', ''))}"
            f"; method {esc(model.get('method') or 'not recorded')}; model file "
            f"{esc(model.get('file') or '(not written)')}</p>")
    table = _table(["parameter", "unit", "estimate", "std. error", "95 % low", "95 % high"],
                   rows, 2)
    corr = model.get("correlation")
    ctab = ""
    if corr:
        names = corr["names"]
        crow = [[f"<code>{esc(n)}</code>"] + [fmt(v, 3) for v in r]
                for n, r in zip(names, corr["matrix"], strict=True)]
        ctab = ("<h3>Correlation of the estimates</h3>"
                + _table([""] + [f"<code>{esc(n)}</code>" for n in names], crow))
    # what identification said about the estimate (poorly determined parameters, ...) and the
    # checks of the model it returned (a standard manoeuvre that diverged, ...)
    notes = "".join(f'<p class="bad">warning: {esc(w)}</p>' for w in model.get("warnings", []))
    notes += "".join(f'<p class="bad">check failed: {esc(c.get("message", ""))}</p>'
                     for c in model.get("checks", []) if isinstance(c, Mapping)
                     and not c.get("passed", True))
    return head + notes + table + ctab + _disturbance(model.get("disturbance"))


def _arrow_svg(towards_deg: float, size: int = 28) -> str:
    """A small inline SVG arrow pointing the way a current flows (north up, clockwise)."""
    h = size / 2
    return (f'<svg width="{size}" height="{size}" viewBox="0 0 {size} {size}" role="img" '
            f'aria-label="towards {towards_deg:.0f} deg" style="vertical-align:middle">'
            f'<circle cx="{h}" cy="{h}" r="{h - 1}" fill="none" stroke="#bbb"/>'
            f'<g transform="rotate({towards_deg:.1f} {h} {h})">'
            f'<line x1="{h}" y1="{size - 4}" x2="{h}" y2="5" stroke="#2e7d32" '
            'stroke-width="2"/>'
            f'<polygon points="{h},2 {h - 4},9 {h + 4},9" fill="#2e7d32"/></g></svg>')


def _disturbance(d: Mapping[str, Any] | None) -> str:
    """What was not logged, estimated per training log (``identification.disturbance``): the
    current as an arrow with its speed and direction, each quantity with its 95 % interval, the
    separability warning; empty without one."""
    if not d or not d.get("trials"):
        return ""
    qs = [("current_north", "current north", "m/s"), ("current_east", "current east", "m/s"),
          ("bias_Y", "sway-force bias", "N"), ("bias_N", "yaw-moment bias", "N m")]
    present = [q for q in qs if any(q[0] in row for row in d["trials"])]
    has_current = any("current_speed_m_s" in row for row in d["trials"])
    rows = []
    for row in d["trials"]:
        cells = [esc(row.get("trial", ""))]
        if has_current:
            if "current_speed_m_s" in row:
                cells.append(f"{_arrow_svg(float(row['current_towards_deg']))} "
                             f"{fmt(row['current_speed_m_s'], 3)} m/s towards "
                             f"{row['current_towards_deg']:.0f} deg")
            else:
                cells.append("&mdash;")
        for q, _, _ in present:
            v = row.get(q)
            if not isinstance(v, Mapping):
                cells.append("&mdash;")
                continue
            lo, hi = (v.get("ci95") or [None, None])[:2]
            cells.append(f"{fmt(v.get('value'), 4)} [{fmt(lo, 3)}, {fmt(hi, 3)}]")
        rows.append(cells)
    head = (["log"] + (["current"] if has_current else [])
            + [f"{label} [{unit}] (95 %)" for _, label, unit in present])
    by = {"regression": "by the regression with the hull (variable projection)"}.get(
        str(d.get("estimated_by")), "by the output error with the hull")
    out = ('<h3 id="disturbance">Disturbance per training log</h3>'
           f"<p>Estimated {esc(by)}: "
           f"{esc(', '.join(d.get('terms', [])))}; the current flows towards the direction "
           "shown (north up). It belongs to the training logs, not to the model: the model "
           "file's hull is the calm-water hull.</p>"
           + _table(head, rows, 1))
    if d.get("warning"):
        out += f'<p class="bad">warning: {esc(d["warning"])}</p>'
    return out


def build_validation_html(run: Mapping[str, Any]) -> str:
    """The report of a validation run (module docstring)."""
    model = run.get("model", {})
    vessel = model.get("vessel", {})
    body = [
        f"<h1>{esc(run.get('title', 'usvid report'))}</h1>",
        f"<p class=\"sub\">{esc(run.get('created_by', ''))}, usvid "
        f"{esc(run.get('usvid_version', ''))}</p>",
        '<h2 class="first" id="model">Model</h2>', _model(model),
        '<h2 id="training">Training trials (the data the model was fitted to)</h2>',
        _trials(run.get("training", []), vessel, "tr"),
        '<h2 id="held-out">Held-out trials (not used in the fit)</h2>',
        _trials(run.get("held_out", []), vessel, "ho"),
    ]
    js = plotly.offline.get_plotlyjs()
    return ("<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>{esc(run.get('title', 'usvid report'))}</title>"
            f"<style>{CSS}{PRINT_CSS}</style>"
            f'<script id="plotly-js">{js}</script></head><body>'
            + "".join(body) + "</body></html>")
