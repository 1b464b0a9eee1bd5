"""The run directory of ``usvid identify --report DIR`` and ``usvid validate --report DIR``:
``run.json`` (everything the report shows) and ``report.html`` built from it
(:mod:`usvid.report.validation_html`); ``usvid report DIR`` rebuilds the HTML from ``run.json``.

``run.json`` (JSON, SI units unless a key names another unit): ``usvid_run`` 1, ``run_kind``
"validation", ``title``, ``created_by``, ``usvid_version``, ``model`` (``kind``, ``file``,
``method``, ``equation``, ``vessel``, ``params`` with ``std_errors``, ``ci95``, ``units``,
``correlation`` {``names``, ``matrix``} when the covariance is known, ``fit``, ``disturbance``
the model file's ``identification.disturbance`` when identified with one), ``training``
and ``held_out`` (one entry per trial: the ``usvid validate`` row plus ``series`` for the
figures, decimated to at most :data:`MAX_POINTS` samples, and ``band`` the 95 % prediction band
of the replay from the parameter uncertainty).

Prediction band: parameters drawn by the one sampler of the stored uncertainty
(:class:`usvid.models.uncertainty.Uncertainty`: the identification covariance, else the standard
errors; seeded; a draw outside the parameter bounds drawn again), each draw replayed on the
trial's measured inputs (:func:`usvid.identify.validation.replay_band`); the band is the
2.5 % .. 97.5 % quantile of the replayed heading and yaw rate at each instant. The trials are
the command's prepared trials (their series built once, shared with the validation).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from usvid import __version__
from usvid.errors import UsvidError
from usvid.identify.validation import TrialValidation, ValidationResult, replay_band
from usvid.models.registry import kind_of
from usvid.models.uncertainty import Uncertainty
from usvid.report.run import save_run, write_report

#: Largest number of samples per time series kept in ``run.json``.
MAX_POINTS = 1500


def _thin(series: dict[str, Any]) -> dict[str, list[float]]:
    out: dict[str, list[float]] = {}
    suffixes = ("_pred", "_env", "_wind")  # (each with its own time t_pred, t_env, t_wind)
    for prefix in ("", *suffixes):
        tkey = "t" + prefix
        if tkey not in series or series[tkey] is None:
            continue
        t = np.asarray(series[tkey], dtype=float)
        step = max(1, int(math.ceil(len(t) / MAX_POINTS)))
        for k, v in series.items():
            own = k.endswith(prefix) if prefix else not k.endswith(suffixes)
            if v is None or (not own and k != tkey):
                continue
            a = np.asarray(v, dtype=float)
            if a.shape == t.shape:
                out[k] = [None if not math.isfinite(x) else round(float(x), 6)
                          for x in a[::step]]
    return out


def _entry(row: TrialValidation, band: dict[str, Any] | None) -> dict[str, Any]:
    d = row.to_dict()
    d["series"] = _thin(row.series)
    if band:
        d["band"] = _thin({"t": row.series.get("t"), **{k: v for k, v in band.items()
                                                         if isinstance(v, np.ndarray)}})
        d["band"].update({k: band[k] for k in ("draws", "redrawn", "failed") if k in band})
    return d


def _model_block(model: Any, file: str | None, unc: Uncertainty | None) -> dict[str, Any]:
    kind = kind_of(model.dynamics)
    ident = getattr(model, "identification", None) or {}
    params = {p.name: float(getattr(model.dynamics, p.name))
              for p in type(model.dynamics).param_specs() if p.fit}
    units = {p.name: p.unit for p in type(model.dynamics).param_specs()}
    out: dict[str, Any] = {
        "kind": kind.name, "file": file, "method": ident.get("method"),
        "equation": getattr(kind, "equation", ""), "params": params,
        "std_errors": ident.get("std_errors", {}), "ci95": ident.get("ci95", {}),
        "units": {k: units.get(k, "") for k in params},
        "fit": ident.get("fit", {}), "data": ident.get("data", []),
        "vessel": model.vessel.to_dict() if model.vessel is not None else {},
        "warnings": list((ident.get("diagnostics") or {}).get("warnings") or []),
        "checks": ident.get("checks", []),
    }
    if ident.get("disturbance"):  # the per-log current / biases of --disturbance
        out["disturbance"] = ident["disturbance"]
    if unc is not None and unc.names:
        c = np.asarray(unc.cov, dtype=float)
        sd = np.sqrt(np.clip(np.diag(c), 0, None))
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = c / np.outer(sd, sd)
        corr[~np.isfinite(corr)] = 0.0
        out["correlation"] = {"names": list(unc.names), "matrix": corr.round(4).tolist()}
    return out


def _bands(model: Any, trials: Sequence[Any], rows: Sequence[TrialValidation],
           unc: Uncertainty | None) -> list[dict[str, Any] | None]:
    out: list[dict[str, Any] | None] = []
    for tr, row in zip(trials, rows, strict=True):
        if not row.replay or unc is None or not unc.names:
            out.append(None)
            continue
        out.append(replay_band(model, tr, unc, water=row.water))
    return out


def _uncertainty(model: Any) -> Uncertainty | None:
    """The model's stored uncertainty (the one reader), None when it has none or it cannot be
    read (the report then shows no band, and says why in the model block)."""
    try:
        return Uncertainty.from_model(model)
    except UsvidError:
        return None


def build_run(model: Any, held: ValidationResult | None, held_trials: Sequence[Any],
              training: ValidationResult | None = None, training_trials: Sequence[Any] = (),
              *, model_file: str | None = None, title: str = "usvid validation report",
              created_by: str = "usvid validate") -> dict[str, Any]:
    """The ``run.json`` dictionary (module docstring)."""
    unc = _uncertainty(model)
    run: dict[str, Any] = {
        "usvid_run": 1, "run_kind": "validation", "title": title, "created_by": created_by,
        "usvid_version": __version__,
        "model": _model_block(model, model_file, unc),
        "training": [], "held_out": [],
    }
    if training is not None:
        bands = _bands(model, training_trials, training.rows, unc)
        run["training"] = [_entry(r, b) for r, b in zip(training.rows, bands, strict=True)]
    if held is not None:
        bands = _bands(model, held_trials, held.rows, unc)
        run["held_out"] = [_entry(r, b) for r, b in zip(held.rows, bands, strict=True)]
    return run


def write_run(run: dict[str, Any], out_dir: str | Path) -> Path:
    """Write ``run.json`` and ``report.html`` into ``out_dir`` (created); returns the report."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    save_run(run, out)
    return write_report(run, out)


def write_validation_report(out_dir: str | Path, res: ValidationResult, trials: Sequence[Any],
                            *, model: Any, model_path: str | Path | None = None) -> Path:
    """``usvid validate --report DIR``: every log held out."""
    run = build_run(model, res, trials, model_file=str(model_path) if model_path else None)
    return write_run(run, out_dir)


def write_identify_report(out_dir: str | Path, est: Any, training: ValidationResult,
                          training_trials: Sequence[Any], held: ValidationResult | None,
                          held_trials: Sequence[Any], *, model_file: str | None = None
                          ) -> Path:
    """``usvid identify --report DIR``: the training trials and the held-out ones
    (``--validate``), with the identification covariance (in the model's identification
    record) for the bands."""
    run = build_run(est.model_, held, held_trials, training, training_trials,
                    model_file=model_file,
                    title=f"usvid identification report: {est.kind} ({est.method})",
                    created_by="usvid identify")
    return write_run(run, out_dir)
