"""The run directory of ``usvid identify --report DIR`` and ``usvid validate --report DIR``:
``run.json`` (everything the report shows) and ``report.html`` built from it
(:mod:`usvid.report.validation_html`); ``usvid report DIR`` rebuilds the HTML from ``run.json``.

``run.json`` (JSON, SI units unless a key names another unit): ``usvid_run`` 1, ``run_kind``
"validation", ``title``, ``created_by``, ``usvid_version``, ``model`` (``kind``, ``file``,
``method``, ``equation``, ``vessel``, ``params`` with ``std_errors``, ``ci95``, ``units``,
``correlation`` {``names``, ``matrix``} when the covariance is known, ``fit``), ``training``
and ``held_out`` (one entry per trial: the ``usvid validate`` row plus ``series`` for the
figures, decimated to at most :data:`MAX_POINTS` samples, and ``band`` the 95 % prediction band
of the replay from the parameter uncertainty).

Prediction band: parameters drawn from N(theta_hat, C) (C the identification covariance, or the
diagonal of the standard errors when a model file carries no covariance; seeded), each draw
replayed on the trial's measured inputs (:func:`usvid.identify.validation.replay_band`); the
band is the 2.5 % .. 97.5 % quantile of the replayed heading and yaw rate at each instant.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from usvid import __version__
from usvid.identify.validation import TrialValidation, ValidationResult, replay_band
from usvid.models.registry import kind_of
from usvid.report.run import save_run, write_report

#: Largest number of samples per time series kept in ``run.json``.
MAX_POINTS = 1500


def _thin(series: dict[str, Any]) -> dict[str, list[float]]:
    out: dict[str, list[float]] = {}
    for prefix in ("", "_pred"):
        tkey = "t" + prefix
        if tkey not in series or series[tkey] is None:
            continue
        t = np.asarray(series[tkey], dtype=float)
        step = max(1, int(math.ceil(len(t) / MAX_POINTS)))
        for k, v in series.items():
            if v is None or (k.endswith("_pred") != bool(prefix) and k != tkey):
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
        d["band"] = _thin({"t": row.series.get("t"), **band})
    return d


def _model_block(model: Any, file: str | None, names: Sequence[str] | None,
                 cov: np.ndarray | None) -> dict[str, Any]:
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
    }
    if cov is not None and names:
        c = np.asarray(cov, dtype=float)
        sd = np.sqrt(np.clip(np.diag(c), 0, None))
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = c / np.outer(sd, sd)
        corr[~np.isfinite(corr)] = 0.0
        out["correlation"] = {"names": list(names), "matrix": corr.round(4).tolist()}
    return out


def _bands(model: Any, trials: Sequence[Any], rows: Sequence[TrialValidation],
           names: Sequence[str] | None, cov: np.ndarray | None) -> list[dict[str, Any] | None]:
    out: list[dict[str, Any] | None] = []
    for tr, row in zip(trials, rows, strict=True):
        if not row.replay or names is None or cov is None:
            out.append(None)
            continue
        out.append(replay_band(model, tr, names, cov))
    return out


def _uncertainty(model: Any, names: Sequence[str] | None, cov: Any
                 ) -> tuple[list[str] | None, np.ndarray | None]:
    if names is not None and cov is not None:
        return list(names), np.asarray(cov, dtype=float)
    se = (getattr(model, "identification", None) or {}).get("std_errors") or {}
    se = {k: v for k, v in se.items() if isinstance(v, int | float) and math.isfinite(v)
          and hasattr(model.dynamics, k)}
    if not se:
        return None, None
    return list(se), np.diag([float(v) ** 2 for v in se.values()])


def build_run(model: Any, held: ValidationResult | None, held_trials: Sequence[Any],
              training: ValidationResult | None = None, training_trials: Sequence[Any] = (),
              *, model_file: str | None = None, names: Sequence[str] | None = None,
              cov: Any = None, title: str = "usvid validation report",
              created_by: str = "usvid validate") -> dict[str, Any]:
    """The ``run.json`` dictionary (module docstring)."""
    names, cov = _uncertainty(model, names, cov)
    run: dict[str, Any] = {
        "usvid_run": 1, "run_kind": "validation", "title": title, "created_by": created_by,
        "usvid_version": __version__,
        "model": _model_block(model, model_file, names, cov),
        "training": [], "held_out": [],
    }
    if training is not None:
        bands = _bands(model, training_trials, training.rows, names, cov)
        run["training"] = [_entry(r, b) for r, b in zip(training.rows, bands, strict=True)]
    if held is not None:
        bands = _bands(model, held_trials, held.rows, names, cov)
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
    (``--validate``), with the identification covariance for the bands."""
    run = build_run(est.model_, held, held_trials, training, training_trials,
                    model_file=model_file, names=list(est.std_errors_), cov=est.cov_,
                    title=f"usvid identification report: {est.kind} ({est.method})",
                    created_by="usvid identify")
    return write_run(run, out_dir)
