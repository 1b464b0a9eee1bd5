"""Assemble the self-contained HTML report from a run dictionary (the content of ``run.json``).

One file, no network: CSS inline, figures as base64 PNG ``data:`` URIs, no scripts, no external
URL anywhere (:func:`external_urls` finds any; text taken from the run is escaped and any
``scheme://`` in it is neutralised so that the file never names a remote resource). Print CSS keeps
figures and tables whole on a page.

The run dictionary's sections are documented in :mod:`usvid.report.run`; every section is
optional, a missing one is shown as "not available" with the reason recorded in ``steps``.
"""

from __future__ import annotations

import html as _html
import math
import re
from collections.abc import Mapping, Sequence
from typing import Any

from usvid.report import figures
from usvid.report.papers_html import SECTION as PAPERS
from usvid.report.papers_html import papers_section

#: Any absolute URL with a scheme a browser would fetch or follow.
_URL_RE = re.compile(r"(?i)\b(?:https?|ftp|wss?)://|(?<![\w.-])//[a-z0-9-]+\.[a-z]{2,}")

CSS = """
:root { --fg:#1b1b1b; --muted:#666; --line:#ddd; --ok:#2e7d32; --warn:#b26a00; --bad:#c62828; }
* { box-sizing: border-box; }
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, sans-serif; color: var(--fg);
       max-width: 1100px; margin: 0 auto; padding: 1.2rem 1.5rem 3rem; line-height: 1.4; }
h1 { font-size: 1.6rem; margin-bottom: .2rem; }
h2 { font-size: 1.25rem; border-bottom: 2px solid var(--line); padding-bottom: .2rem;
     margin-top: 2rem; }
h3 { font-size: 1.05rem; margin-top: 1.4rem; }
p.sub { color: var(--muted); margin-top: 0; }
table { border-collapse: collapse; margin: .5rem 0 1rem; font-size: .86rem; }
th, td { border: 1px solid var(--line); padding: .22rem .5rem; text-align: right; }
th { background: #f4f4f4; }
td.l, th.l { text-align: left; }
.ok { color: var(--ok); font-weight: 600; }
.warn { color: var(--warn); font-weight: 600; }
.bad { color: var(--bad); font-weight: 600; }
.na { color: var(--muted); font-style: italic; }
figure { margin: .6rem 0 1rem; }
figure img { max-width: 100%; height: auto; border: 1px solid #eee; }
figcaption { font-size: .8rem; color: var(--muted); }
.row { display: flex; flex-wrap: wrap; gap: 1rem; align-items: flex-start; }
nav ul { columns: 2; font-size: .9rem; }
code { background: #f6f6f6; padding: 0 .2rem; }
@media print {
  body { max-width: none; padding: 0; font-size: 10pt; }
  nav { display: none; }
  h2 { break-before: page; }
  h2.first { break-before: avoid; }
  figure, table, .keep { break-inside: avoid; page-break-inside: avoid; }
  figure img { max-height: 22cm; border: none; }
  a { color: inherit; text-decoration: none; }
}
@page { size: A4; margin: 14mm; }
"""


def esc(value: Any) -> str:
    """HTML-escape ``value`` and neutralise ``scheme://`` so text never forms an external URL."""
    text = _html.escape(str(value), quote=True)
    return re.sub(r"(?i)\b([a-z][a-z0-9+.-]*):(?=//)", r"\1&#58;", text).replace("//", "&#47;/")


def external_urls(text: str) -> list[str]:
    """Every substring of ``text`` that looks like an external (network) URL."""
    return [m.group(0) for m in _URL_RE.finditer(text)]


def fmt(value: Any, digits: int = 4) -> str:
    """Format a number with ``digits`` significant digits; None/NaN -> an em dash."""
    if value is None:
        return "&mdash;"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            return "&mdash;"
        if value != 0 and (abs(value) >= 1e5 or abs(value) < 1e-3):
            return f"{value:.{digits - 1}e}"
        return f"{value:.{digits}g}"
    if isinstance(value, (list, tuple)):
        return ", ".join(fmt(v, digits) for v in value)
    return esc(value)


def _table(header: Sequence[str], rows: Sequence[Sequence[str]],
           left: int | set[int] = 1) -> str:
    """A table; cells are already HTML. Columns in ``left`` (the first ``left`` if an int, or
    a set of indices) are left aligned, the others (numbers) right aligned."""
    lset = set(range(left)) if isinstance(left, int) else set(left)
    th = "".join(
        f'<th class="l">{h}</th>' if i in lset else f"<th>{h}</th>" for i, h in enumerate(header)
    )
    body = []
    for row in rows:
        tds = "".join(
            f'<td class="l">{c}</td>' if i in lset else f"<td>{c}</td>" for i, c in enumerate(row)
        )
        body.append(f"<tr>{tds}</tr>")
    return f"<table><thead><tr>{th}</tr></thead><tbody>{''.join(body)}</tbody></table>"


def _figure(uri: str, caption: str, alt: str) -> str:
    return (
        f'<figure><img src="{uri}" alt="{esc(alt)}">'
        f"<figcaption>{esc(caption)}</figcaption></figure>"
    )


def _status(status: str) -> str:
    cls = {"ok": "ok", "unavailable": "warn", "skipped": "warn", "failed": "bad"}.get(status, "na")
    return f'<span class="{cls}">{esc(status)}</span>'


def _unavailable(run: Mapping[str, Any], step: str, what: str) -> str:
    for s in run.get("steps", []):
        if s.get("name") == step and s.get("status") != "ok":
            return f'<p class="na">{esc(what)} not available: {esc(s.get("message", ""))}</p>'
    return f'<p class="na">{esc(what)} not available in this run.</p>'


#: Units of the vessel particulars (usvid.trial.Vessel and the campaign extras), SI.
VESSEL_UNITS = {"length": "m", "speed": "m/s", "beam": "m", "draft": "m", "mass": "kg",
                "displacement": "m^3", "block_coefficient": "-", "x_l": "m",
                "frontal_area": "m^2", "lateral_area": "m^2",
                "propeller_D": "m"}
#: Units of the fitted output channels (fit metrics ``<channel>.rmse`` ...), SI.
CHANNEL_UNITS = {"psi": "rad", "r": "rad/s", "u": "m/s", "v": "m/s", "delta": "rad"}


def fit_label(key: str, kind: str = "") -> str:
    """``key`` of a fit-metric entry with its unit: ``r.rmse`` -> ``r.rmse [rad/s]``,
    ``nrmse``/``r2`` -> ``[-]``, ``window_s`` as is (the unit is in the name), ``n`` a count.
    A bare ``rmse``/``max_error`` of the servo model is on delta [rad]."""
    ch, _, metric = key.rpartition(".")
    if not ch and kind == "servo":
        ch = "delta"
    if metric in ("rmse", "max_error") and ch in CHANNEL_UNITS:
        return f"{key} [{CHANNEL_UNITS[ch]}]"
    if metric in ("nrmse", "r2"):
        return f"{key} [-]"
    return key


# --- sections ----------------------------------------------------------------------------------
def _header(run: Mapping[str, Any]) -> str:
    settings = run.get("settings", {})
    vessel = run.get("vessel", {})
    out = [f"<h1>{esc(run.get('title', 'usvid report'))}</h1>"]
    sub = ", ".join(f"{esc(k)} = {fmt(v)}" for k, v in settings.items())
    out.append(f'<p class="sub">{esc(run.get("created_by", "usvid"))}; {sub}</p>')
    if run.get("summary_text"):
        out.append(f"<p>{esc(run['summary_text'])}</p>")
    if vessel:
        rows = [[esc(k), fmt(v), esc(VESSEL_UNITS.get(k, "SI"))] for k, v in vessel.items()]
        out.append('<div class="keep"><h3>Vessel</h3>' + _table(["item", "value", "unit"], rows))
        out.append("</div>")
    return "\n".join(out)


def _steps(run: Mapping[str, Any]) -> str:
    steps = run.get("steps", [])
    if not steps:
        return ""
    rows = [
        [esc(s.get("name", "")), _status(s.get("status", "")), fmt(s.get("seconds")),
         esc(s.get("message", ""))]
        for s in steps
    ]
    total = run.get("timing", {}).get("total_s")
    tail = f"<p>Total wall time: {fmt(total, 3)} s.</p>" if total is not None else ""
    return (
        '<h2 id="steps" class="first">Pipeline</h2>'
        + _table(["step", "status", "time [s]", "note"], rows, left={0, 1, 3})
        + tail
    )


def _campaign(run: Mapping[str, Any]) -> str:
    camp = run.get("campaign")
    out = ['<h2 id="campaign">Trials</h2>']
    if not camp:
        return "".join(out) + _unavailable(run, "campaign", "Trial campaign")
    if camp.get("description"):
        out.append(f"<p>{esc(camp['description'])}</p>")
    rows = []
    for tr in camp.get("trials", []):
        rows.append([
            esc(tr.get("name", "")),
            esc(tr.get("kind", "")),
            fmt(tr.get("delta_deg")),
            fmt(tr.get("psi_deg")),
            fmt(tr.get("duration_s"), 3),
            "<br>".join(esc(f) for f in tr.get("files", [])),
        ])
    out.append(_table(["trial", "manoeuvre", "delta [deg]", "psi switch [deg]", "duration [s]",
                       "log files"], rows, left={0, 1, 5}))
    return "".join(out)


def _audit(run: Mapping[str, Any]) -> str:
    out = ['<h2 id="audit">Data audit</h2>']
    audit = run.get("audit")
    if audit is None:
        return "".join(out) + _unavailable(run, "audit", "Channel audit")
    rows = []
    for entry in audit:
        findings = entry.get("findings", [])
        rejected = entry.get("rejected", {})
        if rejected:
            rej = ", ".join(f"{esc(k)}: {int(v)}" for k, v in rejected.items())
            rows.append([esc(entry.get("trial", "")), '<span class="warn">reader</span>',
                         "rejected_records", f"rejected records ({rej})", ""])
        if not findings:
            rows.append([esc(entry.get("trial", "")), '<span class="ok">ok</span>', "", "no "
                         "findings", ""])
        for f in findings:
            sev = f.get("severity", "info")
            cls = {"error": "bad", "warning": "warn"}.get(sev, "ok")
            rows.append([esc(entry.get("trial", "")), f'<span class="{cls}">{esc(sev)}</span>',
                         esc(f.get("code", "")), esc(f.get("message", "")),
                         fmt(f.get("count"))])
    out.append(_table(["trial", "severity", "code", "finding", "count"], rows, left=4))
    return "".join(out)


def _models(run: Mapping[str, Any]) -> str:
    out = ['<h2 id="models">Identified models</h2>']
    models = run.get("models")
    if not models:
        return "".join(out) + _unavailable(run, "identify", "Model identification")
    if run.get("truth_definition"):
        out.append(f"<p><b>Truth.</b> {esc(run['truth_definition'])}</p>")
    acc = run.get("acceptance")
    if acc:
        def verdict(v: Any) -> str:
            return ('<span class="na">n/a</span>' if v is None else
                    '<span class="ok">yes</span>' if v else '<span class="bad">no</span>')

        def pct(v: Any) -> str:
            return "&mdash;" if v is None else f"{100 * v:.1f} %"

        rows = [["Nomoto K, T within 5 % of the truth", pct(acc.get("nomoto_max_rel_error")),
                 verdict(acc.get("nomoto_within_5pct"))],
                ["3-DOF coefficients within 10 % of the truth",
                 pct(acc.get("threedof_max_rel_error")), verdict(acc.get("threedof_within_10pct"))],
                ["whole demo under 180 s", f"{fmt(acc.get('total_s'), 3)} s",
                 verdict(acc.get("under_180s"))]]
        out.append('<div class="keep"><h3>Acceptance</h3>'
                   + _table(["criterion", "worst / value", "met"], rows) + "</div>")
    for m in models:
        params = m.get("params", {})
        ci = m.get("ci95", {}) or {}
        truth = m.get("truth", {}) or {}
        units = m.get("units", {}) or {}
        rows = []
        for name, value in params.items():
            lo_hi = ci.get(name)
            ci_txt = f"[{fmt(lo_hi[0])}, {fmt(lo_hi[1])}]" if lo_hi else "&mdash;"
            tv = truth.get(name)
            rel = None
            if isinstance(tv, (int, float)) and isinstance(value, (int, float)) and tv != 0:
                rel = 100.0 * (value - tv) / abs(tv)
            rel_txt = "&mdash;" if rel is None else f"{rel:+.1f} %"
            rows.append([esc(name), esc(units.get(name, "")), fmt(value), ci_txt, fmt(tv),
                         rel_txt])
        out.append('<div class="keep">')
        label = m.get("label") or m.get("kind", "")
        out.append(f"<h3>{esc(label)}</h3>")
        if m.get("equation"):
            out.append(f"<p><code>{esc(m['equation'])}</code></p>")
        if m.get("note"):
            out.append(f'<p class="sub">{esc(m["note"])}</p>')
        out.append(_table(["parameter", "unit", "identified", "95 % interval", "truth",
                           "error"], rows, left=2))
        meta = []
        if m.get("method"):
            meta.append(f"method: {esc(m['method'])}")
        if m.get("file"):
            meta.append(f"model file: <code>{esc(m['file'])}</code>")
        for k, v in (m.get("fit") or {}).items():
            if isinstance(v, (int, float)):
                meta.append(f"{esc(fit_label(k, m.get('kind', '')))} = {fmt(v)}")
        if meta:
            out.append(f'<p class="sub">{"; ".join(meta)}</p>')
        out.append("</div>")
    nb = run.get("norrbin_fit")
    if nb:
        out.append(_figure(
            figures.scatter_fit_figure(
                nb.get("delta_deg", []), nb.get("r_deg_s", []), nb.get("curve_delta_deg"),
                nb.get("curve_r_deg_s"), "delta [deg]", "steady r [deg/s]",
                point_label="turning tests (mean r)", curve_label="r + alpha r^3 = K delta"),
            "Norrbin step 2 (Mu et al. 2018 eq. 36): steady yaw rate of the turning tests and the "
            "fitted curve.", "Norrbin steady-turn fit"))
    return "".join(out)


def _metric_rows(metrics: Mapping[str, Any]) -> list[list[str]]:
    meas = metrics.get("measured", {}) or {}
    sim = metrics.get("simulated", {}) or {}
    rows = []
    for key in list(dict.fromkeys([*meas.keys(), *sim.keys()])):
        mv, sv = meas.get(key), sim.get(key)
        if isinstance(mv, Mapping) or isinstance(sv, Mapping):
            continue
        rows.append([esc(key), fmt(mv), fmt(sv)])
    return rows


def _imo_rows(imo: Any) -> list[list[str]]:
    rows = []
    items = imo if isinstance(imo, list) else imo.get("criteria", []) if isinstance(
        imo, Mapping) else []
    if isinstance(imo, Mapping) and not items:
        items = [{"criterion": k, **(v if isinstance(v, Mapping) else {"value": v})}
                 for k, v in imo.items()]
    for c in items:
        passed = c.get("passed", c.get("pass"))
        cls = "ok" if passed else ("bad" if passed is not None else "na")
        rows.append([esc(c.get("criterion", c.get("name", ""))), fmt(c.get("value")),
                     fmt(c.get("limit")), f'<span class="{cls}">'
                     f'{"pass" if passed else ("fail" if passed is not None else "n/a")}</span>'])
    return rows


def _validation(run: Mapping[str, Any]) -> str:
    out = ['<h2 id="validation">Validation: simulated vs measured</h2>']
    val = run.get("validation")
    if not val:
        return "".join(out) + _unavailable(run, "validate", "Validation")
    out.append("<p>Each identified model is driven by the measured propulsion angle (turning) or "
               "by the same zig-zag logic, and compared with the measured trial (Mu et al. 2018, "
               "figures 7-10); each comparison says whether the trial was used in the fit.</p>")
    out.append(_kinds_compared(val))
    roles = {"training": "training trial: in-sample, the model was fitted to it",
             "held out": "held out: not used in the fit"}
    for v in val:
        title = f"{v.get('trial', '')}: {v.get('model', '')}"
        role = v.get("role")
        tag = f' <span class="sub">({esc(roles.get(role, role))})</span>' if role else ""
        out.append(f'<h3>{esc(title)}{tag}</h3><div class="row">')
        if v.get("xy"):
            out.append(_figure(figures.trajectory_figure(v["xy"], title=""),
                               f"Trajectory, {title}", f"trajectory {title}"))
        panels = []
        for ch in v.get("channels", []):
            lines = [{"label": lab, "y": y, "kind": lab} for lab, y in ch.get("lines", {}).items()]
            panels.append({"ylabel": ch.get("ylabel", ch.get("name", "")), "lines": lines})
        if panels and v.get("t"):
            out.append(_figure(figures.timeseries_figure(v["t"], panels),
                               f"Time series, {title}", f"time series {title}"))
        out.append("</div>")
        if v.get("metrics"):
            out.append(_table(["metric", "measured", "simulated"], _metric_rows(v["metrics"])))
        if v.get("fit"):
            out.append('<p class="sub">' + "; ".join(
                f"{esc(k)} = {fmt(x)}" for k, x in v["fit"].items()) + "</p>")
        if v.get("imo"):
            out.append("<p><b>IMO MSC.137(76) criteria</b> (measured trial):</p>")
            out.append(_table(["criterion", "value", "limit", "result"], _imo_rows(v["imo"])))
    return "".join(out)


def _kind_error(v: Mapping[str, Any]) -> str:
    """One trial/model cell: heading RMS error [deg] and the manoeuvre's headline error
    (first overshoot [deg] of a zig-zag, tactical diameter [%] of a turn)."""
    parts = []
    rms = (v.get("fit") or {}).get("psi RMS error [deg]")
    if isinstance(rms, (int, float)):
        parts.append(f"psi RMS {rms:.2f} deg")
    met = v.get("metrics") or {}
    m, s = met.get("measured") or {}, met.get("simulated") or {}
    try:
        if m.get("overshoot_deg") and s.get("overshoot_deg"):
            parts.append(f"1st overshoot {s['overshoot_deg'][0] - m['overshoot_deg'][0]:+.2f} deg")
        elif m.get("tactical_diameter_m") and s.get("tactical_diameter_m"):
            e = 100.0 * (s["tactical_diameter_m"] / m["tactical_diameter_m"] - 1.0)
            parts.append(f"tactical diameter {e:+.1f} %")
    except (TypeError, IndexError, ZeroDivisionError):
        pass
    return esc("; ".join(parts)) if parts else "-"


def _kinds_compared(val: list) -> str:
    """Summary table: one row per trial (with its role), one column per model kind."""
    kinds = list(dict.fromkeys(str(v.get("model", "")) for v in val))
    trials = list(dict.fromkeys((str(v.get("trial", "")), str(v.get("role", ""))) for v in val))
    cell = {(str(v.get("trial", "")), str(v.get("model", ""))): _kind_error(v) for v in val}
    rows = [[esc(f"{t} ({r})" if r else t)] + [cell.get((t, k), "-") for k in kinds]
            for t, r in trials]
    return ("<h3>Model kinds compared</h3><p>Simulated minus measured, per trial; held-out "
            "trials are the test of prediction, training trials only of the fit.</p>"
            + _table(["trial"] + [esc(k) for k in kinds], rows))


def _course_keeping(run: Mapping[str, Any]) -> str:
    out = ['<h2 id="course">Course keeping: the paper\'s and designed PD/PID autopilots</h2>']
    cc = run.get("course_keeping")
    if not cc:
        return "".join(out) + _unavailable(run, "course_keeping", "Course-keeping simulation")
    if cc.get("description"):
        out.append(f"<p>{esc(cc['description'])}</p>")
    out.append(_figure(figures.course_keeping_figure(cc),
                       "Course change 0 -> target under the disturbance of Mu et al. 2018: "
                       "heading, heading error (magnified), rudder angle, disturbance.",
                       "course keeping"))
    paper = cc.get("paper_itae", {})
    rows = []
    for r in cc.get("runs", []):
        rows.append([esc(r.get("label", "")), fmt(r.get("kp")), fmt(r.get("ki")),
                     fmt(r.get("kd")), fmt(r.get("itae")), fmt(r.get("iae")),
                     fmt(r.get("max_rudder_deg")), fmt(paper.get(r.get("label", "")))])
    # gains on the heading error in rad giving delta in rad (usvid.sim course keeping)
    out.append(_table(["controller", "Kp [-]", "Ki [1/s]", "Kd [s]", "ITAE [rad s^2]",
                       "IAE [rad s]", "max |delta| [deg]", "Mu et al. 2018 Table 3 ITAE"], rows))
    return "".join(out)


def _turning_diameter(run: Mapping[str, Any]) -> str:
    out = ['<h2 id="diameter">Turning diameter model (Ma et al.)</h2>']
    td = run.get("turning_diameter")
    if not td:
        return "".join(out) + _unavailable(run, "turning_diameter", "Turning-diameter fit")
    if td.get("description"):
        out.append(f"<p>{esc(td['description'])}</p>")
    out.append('<div class="row">')
    if td.get("points_delta_deg"):
        out.append(_figure(figures.scatter_fit_figure(
            td["points_delta_deg"], td.get("points_D_over_L", []), td.get("curve_delta_deg"),
            td.get("curve_D_over_L"), "delta [deg]", "D / L [-]",
            point_label="measured turning tests", curve_label="fitted eq. 1"),
            "Relative turning diameter vs propulsion angle.", "turning diameter fit"))
    coeffs = td.get("coeffs", {})
    if coeffs:
        rows = [[esc(k), fmt(v)] for k, v in coeffs.items()]
        if td.get("rms") is not None:
            rows.append(["RMS objective F of D/L (eq. 2)", fmt(td["rms"])])
        out.append(_table(["coefficient (dimensionless)", "value [-]"], rows))
    out.append("</div>")
    return "".join(out)


def _nav(sections: Sequence[tuple[str, str]]) -> str:
    items = "".join(f'<li><a href="#{sid}">{esc(t)}</a></li>' for sid, t in sections)
    return f"<nav><ul>{items}</ul></nav>"


def build_html(run: Mapping[str, Any]) -> str:
    """The complete report as one HTML string (UTF-8, no scripts, no external resources).

    ``run`` is the run dictionary (``run.json``); see :mod:`usvid.report.run` for its sections.
    """
    body = [
        _header(run),
        _nav([("steps", "Pipeline"), ("campaign", "Trials"), ("audit", "Data audit"),
              ("models", "Identified models"), ("validation", "Validation"),
              ("course", "Course keeping"), ("diameter", "Turning diameter"), PAPERS]),
        _steps(run),
        _campaign(run),
        _audit(run),
        _models(run),
        _validation(run),
        _course_keeping(run),
        _turning_diameter(run),
        papers_section(run, esc=esc, table=_table, unavailable=_unavailable),
        f'<p class="sub">Generated by usvid {esc(run.get("usvid_version", ""))} from '
        f"<code>run.json</code>; regenerate with <code>usvid report RUN_DIR</code>.</p>",
    ]
    title = esc(run.get("title", "usvid report"))
    return (
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
        '<meta name="viewport" content="width=device-width, initial-scale=1">'
        f"<title>{title}</title><style>{CSS}</style></head>\n<body>\n"
        + "\n".join(body)
        + "\n</body></html>\n"
    )
