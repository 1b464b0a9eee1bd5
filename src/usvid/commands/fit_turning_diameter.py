"""CLI command: ``usvid fit-turning-diameter [TABLE] [--json] [--seed N] [--predict-fr FR
--predict-delta-deg DEG [--level P]]`` (Ma et al.).

Fits Ma et al. eq. 1 to a turning-diameter table (default: Ma et al. Table 2, package data) by the
chaotic GA and by a deterministic global least-squares fit, and evaluates the published eq. 3.
``--json`` prints one object ``{"cga": {...}, "least_squares": {...}, "published_eq3": {...}}``,
each with a1..a5, F (eq. 2), loo_rmse (leave-one-out error; null for the published fit),
max_rel_error, at_bounds and method details. With ``--predict-fr`` and ``--predict-delta-deg``
it adds ``"prediction"``: D/L at that point by each fit and its profile-likelihood interval
(:mod:`usvid.identify.turning_diameter_interval`; keys ``Fr``, ``delta_deg``, ``level``,
``low``, ``high``, ``by_fit``, ``inside_data``, ``ssr_min``, ``ssr_limit``, ``a_low``,
``a_high``, ``a_opt``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from usvid.commands._common import check_seed, emit_json
from usvid.errors import UsvidError


def register(app: typer.Typer) -> None:
    """Register ``usvid fit-turning-diameter`` on the CLI app."""

    @app.command("fit-turning-diameter")
    def fit_turning_diameter_cmd(
        table: Annotated[Path | None, typer.Argument(
            help="CSV with columns Fr, delta_rad, DL_test (Ma et al., Table 2 form) or speed_kn, "
                 "rudder_deg, turning_diameter_m (Table 1 form). Default: Ma et al., Table 2.")
        ] = None,
        json_out: Annotated[bool, typer.Option("--json", help="Print one JSON object.")] = False,
        seed: Annotated[int, typer.Option("--seed", help="Seed of the CGA and of differential "
                                                          "evolution.")] = 0,
        length: Annotated[float, typer.Option("--length", help="Vessel length [m] for a Table 1 "
                                                              "form table.")] = 1.5,
        predict_fr: Annotated[float | None, typer.Option(
            "--predict-fr", help="Froude number of a prediction with its interval (give "
                                 "--predict-delta-deg too).")] = None,
        predict_delta_deg: Annotated[float | None, typer.Option(
            "--predict-delta-deg", help="Rudder angle [deg] of that prediction.")] = None,
        level: Annotated[float, typer.Option(
            "--level", help="Confidence level of the prediction's profile-likelihood "
                            "interval.")] = 0.95,
    ) -> None:
        """Fit Ma et al.'s relative turning diameter D/L(Fr, delta) by CGA and least squares."""
        from usvid.commands._common import check_number
        from usvid.files import check_input
        from usvid.identify.turning_diameter import fit_turning_diameter, load_turning_table

        check_seed(seed)
        check_number(length, "--length", lo=0.0, hi=500.0, lo_open=True, unit="m")
        if table is not None:  # a regular file (a FIFO would block the reader)
            check_input(table, "turning-diameter table")
        if (predict_fr is None) != (predict_delta_deg is None):
            raise UsvidError("--predict-fr and --predict-delta-deg go together (give both)")
        if not 0.0 < level < 1.0:
            raise UsvidError(f"--level must be in (0, 1) (got {level!r})")
        Fr, delta, DL = load_turning_table(table, length=length)
        try:
            fits = fit_turning_diameter(Fr, delta, DL, seed=seed)
            pred = None
            if predict_fr is not None and predict_delta_deg is not None:
                import math

                from usvid.identify.turning_diameter_interval import prediction_interval

                pred = prediction_interval(Fr, delta, DL, predict_fr,
                                           math.radians(predict_delta_deg),
                                           {k: v.coeffs for k, v in fits.items()}, level=level)
        except UsvidError as exc:  # name the table the data came from
            raise UsvidError(f"{table or 'Ma et al. Table 2'}: {exc}") from None
        if json_out:
            out = {k: v.to_dict() for k, v in fits.items()}
            if pred is not None:
                out["prediction"] = pred.to_dict()
            emit_json(out)
            return
        from rich.console import Console
        from rich.table import Table

        t = Table(title=f"Ma et al. eq. 1 fit on {table or 'Ma et al. Table 2'} "
                        f"(N = {Fr.size}, F = RMS of D/L, eq. 2)")
        for col in ("method", "a1", "a2", "a3", "a4", "a5", "F", "LOO RMS", "max rel err",
                    "at bounds"):
            t.add_column(col, justify="left" if col in ("method", "at bounds") else "right")
        for name, f in fits.items():
            a = f.coeffs.as_array()
            t.add_row(name, *(f"{v:.4f}" for v in a), f"{f.F:.4f}",
                      "-" if f.loo_rmse is None else f"{f.loo_rmse:.4f}",
                      f"{100 * f.max_rel_error:.1f} %", ", ".join(f.at_bounds) or "-")
        console = Console()
        Console(width=max(console.width, 112)).print(t)  # 10 columns need ~110 characters
        if pred is not None:
            where = "inside" if pred.inside_data else "outside"
            print(f"D/L at Fr {pred.Fr:g}, delta {predict_delta_deg:g} deg ({where} the data): "
                  + ", ".join(f"{k} {v:.3f}" for k, v in pred.by_fit.items())
                  + f"; {100 * pred.level:g} % profile-likelihood interval "
                    f"{pred.low:.3f} .. {pred.high:.3f}")
