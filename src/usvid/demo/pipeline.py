"""``usvid demo``: the whole chain on the virtual Lanxin sea-trial campaign (Mu et al. 2018).

Steps (each timed, each recorded in ``run.json`` with its status):

1. ``campaign``   generate the seeded virtual trials as NMEA 0183 / candump / CSV log files
                  (:mod:`usvid.demo.campaign`) under ``OUT/logs`` (moved in place when complete);
2. ``read``       read them back with :mod:`usvid.io` (the logs are the only input from here on);
3. ``audit``      channel audit (:func:`usvid.prep.audit`) and preparation to a uniform grid;
4. ``identify``   servo (second order + dead time), Nomoto 1st order, Norrbin in Mu et al. 2018's
                  two steps (Nomoto on the 10/10 zig-zag, alpha from the turning tests, eq. 36) and
                  the 3-DOF model (Mu et al. 2018 eq. 37) with :mod:`usvid.identify`;
5. ``validate``   identified models simulated through the same manoeuvres, against the logs
                  (Mu et al. 2018 figures 7-10), manoeuvre metrics and IMO criteria;
6. ``course_keeping``  PD vs PID course change 0 -> 100 deg under the Mu et al. 2018 disturbance,
                  ITAE (Mu et al. 2018 section 6.1, Table 3);
7. ``turning_diameter``  the Ma et al. relative turning-diameter model fitted by the chaotic GA;
8. ``papers``     the papers' headline numbers on the shipped example models
                  (:mod:`usvid.demo.papers`, the rows of docs/papers.md it covers);
9. ``write``      model files (``OUT/models/*.json``), ``run.json`` and ``report.html``.

A step whose input is missing because an earlier step failed is recorded as ``skipped``; an
exception inside a step is recorded as ``failed`` with its message. Nothing is faked. Every
output is written atomically, so an interrupted demo never leaves a half-written file.
"""

from __future__ import annotations

import importlib.util
import math
import os
import shutil
import tempfile
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from rich.console import Console
from rich.markup import escape
from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn
from rich.table import Table

from usvid import __version__
from usvid.control.design import design_autopilot
from usvid.demo.analysis import course_keeping, turning_diameter_fit, validate_against
from usvid.demo.campaign import generate_campaign, read_campaign_trial
from usvid.demo.papers import papers_entry
from usvid.errors import UsvidError, raised_by_interrupt
from usvid.files import claim_output_dir, move_into, to_json, write_atomic
from usvid.identify.estimator import identify
from usvid.identify.servo import identify_second_order_servo
from usvid.io.modelfile import save_model
from usvid.manoeuvres.detect import find_execute, steady_turn
from usvid.models.registry import get as get_kind
from usvid.prep import audit, prepare
from usvid.report.run import save_run, write_report

#: Mu et al. 2018 section 6.1 controller gains and Table 3 ITAE.
PID_GAINS = {"PD": (0.7, 0.0, 1.0), "PID": (0.7, 0.00095, 1.0)}
PAPER_ITAE = {"PID": 37.98, "PD": 38.6}
COURSE_TARGET_DEG = 100.0
#: Disturbance std [deg] of the course-keeping simulation (a rudder-equivalent disturbance).
COURSE_DIST_DEG = 1.0
#: Duration of the course-change simulation [s]: the ITAE horizon, the same 100 s as the
#: defaults of ``usvid simulate course-keeping`` and ``usvid autopilot`` (Mu et al. 2018 do
#: not state theirs).
COURSE_T_END_S = 100.0


def designed_gains(model: Any, u0: float, seed: int) -> dict[str, tuple[float, float, float]]:
    """PD and PID gains designed by pole placement (:func:`usvid.control.design_autopilot`,
    Fossen 2021, Sec. 15.3) on the identified model at ``u0`` [m/s], labelled for the report
    next to Mu et al. 2018's hand-tuned gains; none when the model admits no design."""
    out = {}
    for ctrl in ("pd", "pid"):
        try:
            d = design_autopilot(model, controller=ctrl, samples=0, u0=u0, seed=seed,
                                 disturbance_deg=COURSE_DIST_DEG, horizon=COURSE_T_END_S,
                                 target_deg=COURSE_TARGET_DEG, realisations=1)
        except UsvidError:
            continue
        out[f"designed {ctrl.upper()}"] = (d.gains.kp, d.gains.ki, d.gains.kd)
    return out


class Skipped(Exception):
    """A step's input is missing because an earlier step did not complete."""


@dataclass
class DemoResult:
    """The outcome: the run dict (``run.json``), where it went, and the exit code (0 unless a
    step failed with an exception)."""

    run: dict[str, Any]
    out: Path
    report: Path | None
    exit_code: int
    state: dict[str, Any] = field(default_factory=dict)


class _Progress:
    """Rich progress on stderr (falls back to plain lines when not a terminal)."""

    def __init__(self, enabled: bool) -> None:
        self.enabled = enabled
        self._progress = None
        if enabled:
            self.console = Console(stderr=True)
            self._progress = Progress(SpinnerColumn(), TextColumn("{task.description}"),
                                      TimeElapsedColumn(), console=self.console, transient=False)

    def __enter__(self) -> _Progress:
        if self._progress is not None:
            self._progress.__enter__()
        return self

    def __exit__(self, *exc: Any) -> None:
        if self._progress is not None:
            self._progress.__exit__(*exc)

    def start(self, label: str) -> Any:
        if self._progress is None:
            return None
        return self._progress.add_task(label, total=1)

    def done(self, task: Any, label: str, status: str, seconds: float, message: str) -> None:
        if self._progress is None:
            return
        mark = {"ok": "[green]done[/]", "skipped": "[yellow]skipped[/]",
                "failed": "[red]FAILED[/]"}[status]
        short = (message[:90] + "...") if len(message) > 93 else message
        self._progress.update(task, completed=1,
                              description=f"{label}: {mark} [dim]{escape(short)}[/]")


class DemoPipeline:
    """The demo's steps over a shared ``state`` dict, recording into ``run``."""

    def __init__(self, out: Path, seed: int = 1, quick: bool = False,
                 progress: bool = False) -> None:
        self.out = Path(out)
        self.seed = int(seed)
        self.quick = bool(quick)
        self.state: dict[str, Any] = {}
        self.progress = _Progress(progress)
        self.run: dict[str, Any] = {
            "usvid_run": 1,
            "title": "usvid demo: virtual Lanxin USV sea trials (Mu et al. 2018)",
            "created_by": "usvid demo",
            "usvid_version": __version__,
            "settings": {"seed": self.seed, "quick": self.quick},
            "steps": [],
        }

    # -- step runner -------------------------------------------------------------------------
    def step(self, name: str, label: str, fn: Callable[[], str | None]) -> bool:
        task = self.progress.start(label)
        t0 = time.perf_counter()
        status, message, tb = "ok", "", None
        try:
            message = fn() or ""
        except Skipped as exc:
            status, message = "skipped", str(exc)
        except KeyboardInterrupt:
            raise
        except Exception as exc:  # a bug or bad data in a present step: record, go on
            if raised_by_interrupt(exc):  # (a library's clean-up failing under Ctrl-C)
                raise KeyboardInterrupt from exc
            status, message = "failed", f"{type(exc).__name__}: {exc}"
            tb = traceback.format_exc(limit=6)
        seconds = time.perf_counter() - t0
        entry = {"name": name, "label": label, "status": status, "seconds": round(seconds, 3),
                 "message": " ".join(str(message).split())}
        if tb and os.environ.get("USVID_DEMO_TRACEBACK"):
            entry["traceback"] = tb
        self.run["steps"].append(entry)
        self.state.setdefault("tracebacks", {})[name] = tb
        self.progress.done(task, label, status, seconds, entry["message"])
        return status == "ok"

    def require(self, *keys: str) -> list[Any]:
        missing = [k for k in keys if k not in self.state]
        if missing:
            raise Skipped(f"needs {', '.join(missing)} from an earlier step")
        return [self.state[k] for k in keys]

    # -- 1. campaign -------------------------------------------------------------------------
    def step_campaign(self) -> str:
        logs = self.out / "logs"
        # generated in a temporary folder of its own, then moved into logs/ file by file: files
        # of logs/ with other names (the user's) are never deleted or modified
        tmp = Path(tempfile.mkdtemp(prefix=".logs.", suffix=".tmp", dir=self.out))
        try:
            # the first zig-zag also as a ROS 2 bag when the usvid[ros] extra is installed
            camp = generate_campaign(tmp, seed=self.seed, quick=self.quick,
                                     ros2_bag=importlib.util.find_spec("rosbags") is not None)
            move_into(tmp, logs)
        finally:
            shutil.rmtree(tmp, ignore_errors=True)  # only the temporary folder it created
        camp.relocate(tmp, logs)
        self.state["campaign"] = camp
        self.run["vessel"] = camp.vessel
        self.run["campaign"] = camp.summary(relative_to=self.out)
        self.run["truth_definition"] = camp.truth_definition
        return f"{len(camp.trials)} trials, {sum(len(t.files) for t in camp.trials)} log files"

    # -- 2. read ------------------------------------------------------------------------------
    def step_read(self) -> str:
        (camp,) = self.require("campaign")
        trials = {}
        for ct in camp.trials:
            trials[ct.manoeuvre.name] = read_campaign_trial(ct)
        self.state["raw"] = trials
        n = sum(len(t) for t in trials.values())
        rej = sum(sum(t.rejected.values()) for t in trials.values())
        return f"{len(trials)} trials, {n} records, {rej} rejected"

    # -- 3. audit + prepare --------------------------------------------------------------------
    def step_audit(self) -> str:
        (raw,) = self.require("raw")
        prepared, entries, n_find = {}, [], 0
        for name, tr in raw.items():
            findings = audit(tr)
            n_find += len(findings)
            entries.append({"trial": name, "findings": [f.to_dict() for f in findings],
                            "rejected": dict(tr.rejected)})
            prepared[name] = prepare(tr, rate_hz=50.0)
        self.run["audit"] = entries
        self.state["trials"] = prepared
        return f"{n_find} findings over {len(raw)} trials; resampled to 50 Hz"

    # -- 4. identify ---------------------------------------------------------------------------
    def step_identify(self) -> str:
        (trials, camp) = self.require("trials", "campaign")
        zz, zz_val = trials["zigzag_10_10"], trials["zigzag_15_15"]
        turns = [trials[k] for k in sorted(trials) if k.startswith("turning_")]
        truth = camp.truth
        models, notes = [], []

        # servo: second order + dead time from commanded vs actual angle (Mu et al. 2018,
        # sec. 5.1.3); the identified models carry the same fit (the estimator's "auto" servo)
        dt = float(np.median(np.diff(zz.t)))
        sid = identify_second_order_servo(*_finite_pair(zz["delta_cmd"], zz["delta"]), dt)
        servo = {"kind": "second_order", "omega_n": float(sid.omega_n), "zeta": float(sid.zeta),
                 "gain": float(sid.gain), "delay": float(sid.delay), "max_angle_deg": 35.0}
        self.state["servo"] = servo
        models.append(_model_entry(
            "servo", "Servo: 2nd order + dead time (Mu et al. 2018, eq. 12)",
            "delta/delta_cmd = gain wn^2/(s^2 + 2 zeta wn s + wn^2) e^(-delay s)",
            {k: servo[k] for k in ("omega_n", "zeta", "gain", "delay")},
            {**getattr(sid, "ci95", {}), "delay": None}, truth.get("servo", {}),
            {"omega_n": "rad/s", "zeta": "-", "gain": "-", "delay": "s"},
            getattr(sid, "method", "arx+oe"), _fit_dict(getattr(sid, "fit", None)),
            "models/servo.json"))
        ident: dict[str, Any] = {}
        # Nomoto 1st order from the zig-zag tests. Mu et al. 2018 had one 10/10 zig-zag; the
        # campaign has a 15/15 too, and fitting both halves the variance of T. The turning
        # tests stay held out for Nomoto.
        ident["nomoto1"] = identify([zz, zz_val], "nomoto1", "oe")
        # Norrbin, Mu et al. 2018's two steps: K, T from the zig-zags, alpha from the turns
        ident["norrbin"] = identify([zz, zz_val], "norrbin", "oe", norrbin="two_step",
                                    turning=turns)
        # 3-DOF (eq. 37): every trial (the speed steps separate the surge damping from the
        # thrust), least squares refined by output error; the thruster arm and the propeller
        # come from the logs' format spec (vessel block), as for any user
        tdof_data = [zz, zz_val, *turns] + ([trials["speed_steps"]] if "speed_steps" in trials
                                            else [])
        ident["threedof"] = identify(tdof_data, "threedof", "oe")
        for kind, res in ident.items():
            _relative_sources(res.model.identification, self.out)
            self.state.setdefault("model_files", {})[kind] = res.model
            spec = get_kind(kind)
            units = {p.name: p.unit for p in spec.dynamics.param_specs()}
            models.append(_model_entry(
                kind, f"{spec.title} ({spec.reference})", spec.equation, dict(res.params),
                dict(res.ci95), truth.get(kind, {}), {k: units.get(k, "") for k in res.params},
                res.method, _fit_dict(res.fit), f"models/{kind}.json"))
        lin = camp.truth_extra.get("nomoto_linearised")
        for m in models:
            if m["kind"] == "nomoto1" and lin:
                m["note"] = (
                    f"For comparison: the small-signal linearisation of the 3-DOF model at "
                    f"{lin['u0']:.3g} m/s (Nomoto 2nd order, Mu et al. 2018, eq. 29) "
                    f"K = {lin['K']:.4g} 1/s, T1 = {lin['T1']:.4g} s, T2 = {lin['T2']:.4g} s, "
                    f"T3 = {lin['T3']:.4g} s (T1 + T2 - T3 = {lin['T']:.4g} s).")
            if m["kind"] == "threedof":
                m["note"] = ("Identified from the seven trials other than the held-out 20/20 "
                             "(Mu et al. 2018 used the 10/10 zig-zag alone, which cannot "
                             "separate the surge damping from the thrust at one shaft speed).")
        self.state["identified"] = ident
        self.run["models"] = models
        nb = _norrbin_curve(ident["norrbin"], turns)
        if nb:
            self.run["norrbin_fit"] = nb
        nom = ident["nomoto1"].params
        notes.append(f"K = {nom['K']:.4g} 1/s, T = {nom['T']:.4g} s")
        return "; ".join(notes)

    # -- 5. validate ---------------------------------------------------------------------------
    def step_validate(self) -> str:
        (trials, ident, camp) = self.require("trials", "identified", "campaign")
        entries = []
        kinds = ["nomoto1", "threedof"]
        if "norrbin" in ident and norrbin_turns_everywhere(ident["norrbin"].params):
            kinds.insert(1, "norrbin")
        for model_kind in kinds:
            if model_kind not in ident:
                continue
            used = " ".join(str(d.get("file", d)) for d in ident[model_kind].data)
            for tname in ("zigzag_20_20", "zigzag_15_15", "zigzag_10_10", "turning_35",
                          "turning_10"):
                if tname in trials:
                    e = validate_against(ident[model_kind].model, trials[tname],
                                         camp.manoeuvre(tname), model_kind, camp)
                    # in-sample or not: said in the report next to every comparison
                    e["role"] = "training" if tname in used else "held out"
                    entries.append(e)
        self.run["validation"] = entries
        return f"{len(entries)} comparisons"

    # -- 6. course keeping ---------------------------------------------------------------------
    def step_course_keeping(self) -> str:
        (ident, camp) = self.require("identified", "campaign")
        kind = ("norrbin" if "norrbin" in ident
                and norrbin_turns_everywhere(ident["norrbin"].params) else "nomoto1")
        gains = dict(PID_GAINS)
        gains.update(designed_gains(ident[kind].model, float(camp.vessel["speed"]), self.seed))
        cc = course_keeping(ident[kind].model, camp, seed=self.seed, gains=gains,
                    target_deg=COURSE_TARGET_DEG, dist_deg=COURSE_DIST_DEG,
                    t_end=COURSE_T_END_S)
        cc["model"] = kind
        cc["description"] = cc["description"].replace("Identified Norrbin model",
                                                      f"Identified {kind} model") + (
            " PD and PID: Mu et al. 2018's hand-tuned gains; designed PD/PID: Fossen's pole "
            "placement on the identified model with its servo (usvid autopilot).")
        cc["paper_itae"] = PAPER_ITAE
        self.run["course_keeping"] = cc
        return f"{kind} model; " + ", ".join(f"{r['label']} ITAE {r['itae']:.4g}"
                                             for r in cc["runs"])

    # -- 7. turning diameter -------------------------------------------------------------------
    def step_turning_diameter(self) -> str:
        td = turning_diameter_fit(seed=self.seed, quick=self.quick)
        self.run["turning_diameter"] = td
        return f"RMS {td['rms']:.4g} (published eq. 3: {td.get('rms_published', float('nan')):.4g})"

    # -- 8. papers ------------------------------------------------------------------------------
    def step_papers(self) -> str:
        entry = papers_entry()
        self.run["papers"] = entry
        return f"{len(entry['rows'])} headline numbers"

    # -- 9. write ------------------------------------------------------------------------------
    def write_models(self) -> list[Path]:
        paths = []
        for kind, model in sorted(self.state.get("model_files", {}).items()):
            paths.append(save_model(model, self.out / "models" / f"{kind}.json"))
        servo = self.state.get("servo")
        if servo is not None:
            paths.append(write_atomic(self.out / "models" / "servo.json",
                                      to_json({"usvid_servo": 1, **servo}) + "\n"))
        return paths

    def execute(self) -> DemoResult:
        t_start = time.perf_counter()
        with self.progress:
            self.step("campaign", "Generate virtual Lanxin campaign (logs)", self.step_campaign)
            self.step("read", "Read logs (NMEA 0183, candump, CSV)", self.step_read)
            self.step("audit", "Audit and prepare channels", self.step_audit)
            self.step("identify", "Identify servo, Nomoto, Norrbin, 3-DOF", self.step_identify)
            self.step("validate", "Validate: simulated vs measured", self.step_validate)
            self.step("course_keeping", "Course keeping: paper and designed PD/PID (ITAE)",
                      self.step_course_keeping)
            self.step("turning_diameter", "Turning-diameter fit (Ma et al., CGA)",
                      self.step_turning_diameter)
            self.step("papers", "The papers' headline numbers", self.step_papers)
        self.run["timing"] = {"total_s": round(time.perf_counter() - t_start, 3)}
        self.run["acceptance"] = acceptance(self.run)
        self.run["summary_text"] = _summary_text(self.run)
        self.write_models()
        save_run(self.run, self.out)
        report = write_report(self.run, self.out)
        failed = any(s["status"] == "failed" for s in self.run["steps"])
        return DemoResult(self.run, self.out, report, 1 if failed else 0, self.state)


# --- helpers -----------------------------------------------------------------------------------
def _finite_pair(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two channels of a uniform grid trimmed to where both are finite at the ends, interior
    gaps (multi-rate logs resampled) filled by linear interpolation."""
    ok = np.isfinite(a) & np.isfinite(b)
    if not ok.any():
        return a, b
    i0, i1 = int(np.argmax(ok)), len(ok) - int(np.argmax(ok[::-1]))
    idx = np.arange(i0, i1)
    out = []
    for x in (a, b):
        good = np.isfinite(x[idx])
        out.append(np.interp(idx, idx[good], x[idx][good]))
    return out[0], out[1]


def norrbin_turns_everywhere(params: dict[str, float],
                             delta_max: float = math.radians(35.0)) -> bool:
    """True when ``n1 r + n3 r^3 = K delta`` has a steady turn for every |delta| <= delta_max.

    With n3 < 0 (and n1 > 0) the left side peaks at ``r* = sqrt(n1 / (-3 n3))`` with value
    ``2/3 n1 r*``; a larger ``K delta_max`` has no steady solution and the simulated yaw rate
    runs away, so such a model is not used for simulation.
    """
    K, n1, n3 = params.get("K", 0.0), params.get("n1", 1.0), params.get("n3", 0.0)
    if n3 >= 0:
        return n1 > 0 or n3 > 0
    if n1 <= 0:
        return False
    r_star = math.sqrt(n1 / (-3.0 * n3))
    return (2.0 / 3.0) * n1 * r_star > abs(K) * delta_max


def _relative_sources(ident: dict[str, Any], base: Path) -> dict[str, Any]:
    """A model's identification record with its data paths relative to the run folder (so that
    the same seed gives byte-identical model files wherever the run is written)."""

    def rel(p: str) -> str:
        try:
            return Path(p).resolve().relative_to(base.resolve()).as_posix()
        except (ValueError, OSError):
            return p

    if isinstance(ident.get("data"), list):
        ident["data"] = [rel(p) for p in ident["data"]]
    if isinstance(ident.get("data_sha256"), dict):
        ident["data_sha256"] = {rel(k): v for k, v in ident["data_sha256"].items()}
    return ident


def acceptance(run: dict[str, Any]) -> dict[str, Any]:
    """The demo's acceptance numbers: Nomoto K, T within 5 % and the 3-DOF coefficients within
    10 % of the simulation truth, total time under 180 s (``None`` where not computed)."""
    models = {m["kind"]: m for m in run.get("models", [])}

    def worst(kind: str, names: tuple[str, ...] | None = None) -> float | None:
        rel = models.get(kind, {}).get("rel_error", {})
        vals = [abs(v) for k, v in rel.items() if names is None or k in names]
        return max(vals) if vals else None

    nom = worst("nomoto1", ("K", "T"))
    tdof = worst("threedof")
    total = run.get("timing", {}).get("total_s")
    return {
        "nomoto_max_rel_error": nom, "nomoto_within_5pct": None if nom is None else nom <= 0.05,
        "threedof_max_rel_error": tdof,
        "threedof_within_10pct": None if tdof is None else tdof <= 0.10,
        "total_s": total, "under_180s": None if total is None else total < 180.0,
    }


def _fit_dict(fit: Any) -> dict[str, Any]:
    if fit is None:
        return {}
    if hasattr(fit, "to_dict"):
        fit = fit.to_dict()
    if not isinstance(fit, dict):
        return {}
    out = {}
    for k, v in fit.items():
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            out[k] = float(v)
        elif isinstance(v, dict):
            for k2, v2 in v.items():
                if isinstance(v2, (int, float)) and not isinstance(v2, bool):
                    out[f"{k}.{k2}"] = float(v2)
    return dict(list(out.items())[:8])


def _model_entry(kind: str, label: str, equation: str, params: dict, ci95: dict, truth: dict,
                 units: dict, method: str, fit: dict, file: str) -> dict[str, Any]:
    params = {k: float(v) for k, v in params.items() if v is not None}
    ci = {k: [float(v[0]), float(v[1])] for k, v in (ci95 or {}).items()
          if v is not None and k in params and np.all(np.isfinite(v))}
    truth = {k: float(v) for k, v in (truth or {}).items() if k in params and v is not None}
    rel = {k: (params[k] - truth[k]) / abs(truth[k]) for k in truth if truth[k] != 0}
    return {"kind": kind, "label": label, "equation": equation, "params": params, "ci95": ci,
            "truth": truth, "rel_error": rel, "units": units, "method": method, "fit": fit,
            "file": file}


def _norrbin_curve(nor: Any, turns: list) -> dict[str, Any] | None:
    """Steady turns (mean delta and r over the steady part of each turning trial,
    :func:`usvid.manoeuvres.detect.steady_turn` from the rudder execute) and the fitted curve
    ``r + alpha r^3 = K delta`` (Mu et al. 2018 eq. 36) for the report."""
    p = nor.params
    K, n1, n3 = p.get("K"), p.get("n1", 1.0), p.get("n3")
    if K is None or n3 is None:
        return None
    d_deg, r_deg = [], []
    for tr in turns:
        st = steady_turn(tr.t, tr["psi"], find_execute(tr.t, tr["delta"])[0], r=tr["r"],
                         delta=tr["delta"])
        d_deg.append(math.degrees(st.delta))
        r_deg.append(math.degrees(st.yaw_rate))
    rr = np.linspace(0.0, max(np.radians(max(r_deg)) * 1.15, 0.05), 60)
    dd = (n1 * rr + n3 * rr ** 3) / K
    return {"delta_deg": d_deg, "r_deg_s": r_deg, "curve_delta_deg": np.degrees(dd).tolist(),
            "curve_r_deg_s": np.degrees(rr).tolist()}


def _summary_text(run: dict[str, Any]) -> str:
    steps = run.get("steps", [])
    bad = [s["name"] for s in steps if s["status"] != "ok"]
    total = run.get("timing", {}).get("total_s")
    head = f"{len(steps) - len(bad)} of {len(steps)} steps completed in {total:.1f} s."
    if bad:
        head += " Not completed: " + ", ".join(bad) + " (see the Pipeline table)."
    return head


def summary_rows(run: dict[str, Any]) -> list[tuple[str, str, str, str, str, str]]:
    """(model, parameter, identified, 95 % interval, truth, error) rows for the final table."""
    rows = []
    for m in run.get("models", []):
        for k, v in m.get("params", {}).items():
            ci = m.get("ci95", {}).get(k)
            tv = m.get("truth", {}).get(k)
            rel = m.get("rel_error", {}).get(k)
            rows.append((m["kind"], k, f"{v:.5g}",
                         f"[{ci[0]:.4g}, {ci[1]:.4g}]" if ci else "-",
                         f"{tv:.5g}" if tv is not None else "-",
                         f"{100 * rel:+.1f} %" if rel is not None else "-"))
    return rows


def print_summary(result: DemoResult) -> None:
    """The final rich table (stderr): identified parameters next to the truth, step status."""
    console = Console()
    table = Table(title="Identified parameters vs simulation truth")
    for col in ("model", "parameter", "identified", "95 % interval", "truth", "error"):
        table.add_column(col, justify="left" if col in ("model", "parameter") else "right")
    for row in summary_rows(result.run):
        table.add_row(*row)
    console.print(table)
    cc = result.run.get("course_keeping")
    if cc:
        t2 = Table(title="Course change 0 -> 100 deg under disturbance")
        for col in ("controller", "ITAE", "IAE", "max |delta| [deg]", "Mu et al. 2018 Table 3"):
            t2.add_column(col, justify="right")
        def num(v: Any, f: str = ".4g") -> str:
            return "-" if v is None or not math.isfinite(v) else format(v, f)

        for r in cc.get("runs", []):
            t2.add_row(r["label"], num(r.get("itae")), num(r.get("iae")),
                       num(r.get("max_rudder_deg"), ".3g"), num(PAPER_ITAE.get(r["label"])))
        console.print(t2)
    acc = result.run.get("acceptance", {})
    if acc.get("nomoto_max_rel_error") is not None:
        console.print(f"Nomoto K, T worst error {100 * acc['nomoto_max_rel_error']:.1f} % "
                      f"(within 5 %: {'yes' if acc['nomoto_within_5pct'] else 'NO'})")
    if acc.get("threedof_max_rel_error") is not None:
        console.print(f"3-DOF coefficients worst error {100 * acc['threedof_max_rel_error']:.1f} %"
                      f" (within 10 %: {'yes' if acc['threedof_within_10pct'] else 'NO'})")
    for s in result.run.get("steps", []):
        if s["status"] != "ok":
            console.print(f"[yellow]step {s['name']}: {s['status']}[/] - {s['message']}")
    console.print(f"report: {result.report}")
    console.print(f"total {result.run.get('timing', {}).get('total_s', 0):.1f} s")


def run_demo(out: str | Path = "demo-out", seed: int = 1, quick: bool = False,
             progress: bool = False, force: bool = False) -> DemoResult:
    """Run the whole demo into ``out``; returns a :class:`DemoResult` (see module docstring).

    ``seed``: 0 <= seed < 2**32. ``out`` is claimed with :func:`usvid.files.claim_output_dir`:
    a non-empty folder that usvid did not create is refused unless ``force``; nothing the demo
    did not create is ever deleted. Raises :class:`UsvidError` before writing anything when
    ``seed`` or ``out`` is unusable.
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not (
            0 <= int(seed) < 2**32):
        raise UsvidError(f"--seed must be an integer in 0 .. {2**32 - 1} (got {seed!r})")
    out = claim_output_dir(out, force=force, command="usvid demo")
    return DemoPipeline(Path(out), seed=int(seed), quick=quick, progress=progress).execute()
