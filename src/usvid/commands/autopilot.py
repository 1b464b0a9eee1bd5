"""CLI: ``usvid autopilot MODEL.json [--method pole-placement|itae] ...``.

Designs heading-autopilot gains from a model file (:func:`usvid.control.design_autopilot`) and
prints them with the predicted 0 -> target course change (ITAE [rad s^2] over the stated
horizon, overshoot, rudder saturation), the same metrics of the reference gains (Mu et al.
2018's hand-tuned kp 0.7, ki 0.00095, kd 1) under the same horizon and disturbance seed, the
margins and the robustness over samples of the parameter uncertainty. ``--json``: one object
(``method``, ``kp``, ``ki``, ``kd``, ``controller``, ``horizon_s``, ``step``, ``reference``,
``margins``, ``robustness``, ...). The environment options of ``usvid simulate``
(:func:`usvid.commands._common.environment_of`): the design, its step, the reference and the
robustness are in that environment; ``environment`` echoes it (null in calm water) and
``in_environment`` gives the design's and the reference's ITAE in calm water and in the
environment (``itae_calm``, ``itae_environment``, ``reference_itae_calm``,
``reference_itae_environment`` [rad s^2], stream 0; the means over the realisations; the calm
step metrics).
"""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path
from typing import Annotated, Any

import typer

from usvid.commands._common import (
    Controller,
    CurrentDirOpt,
    CurrentSpeedOpt,
    HsOpt,
    TpOpt,
    WaveDirOpt,
    WindDirOpt,
    WindSpeedOpt,
    check_disturbance_deg,
    check_dt,
    check_number,
    check_seed,
    check_speed,
    check_steps,
    check_target_deg,
    environment_of,
)
from usvid.errors import UsvidError


class Method(StrEnum):
    pole_placement = "pole-placement"
    itae = "itae"


def autopilot_cmd(
    model_path: Annotated[Path, typer.Argument(help="Model file (JSON, usvid_model: 1).",
                                               show_default=False)],
    method: Annotated[Method, typer.Option(
        "--method", help="pole-placement (Fossen) or itae (minimised on the model).")] =
        Method.pole_placement,
    controller: Annotated[Controller, typer.Option("--controller", help="pd or pid.")] =
        Controller.pd,
    bandwidth: Annotated[float | None, typer.Option(
        "--bandwidth", help="Closed-loop bandwidth [rad/s] of the pole placement (default: "
        "the largest with 6 dB gain and 45 deg phase margin).")] = None,
    zeta: Annotated[float, typer.Option("--zeta", help="Closed-loop relative damping.")] = 0.8,
    disturbance_deg: Annotated[float, typer.Option(
        "--disturbance-deg", help="Disturbance std [deg] (Mu et al. 2018 filter); 0 = calm.")]
        = 1.0,
    horizon: Annotated[float, typer.Option(
        "--horizon", help="Horizon [s] of every ITAE (the run is 0 .. horizon).")] = 100.0,
    target_deg: Annotated[float, typer.Option("--target-deg", help="Course change [deg].")] =
        100.0,
    seed: Annotated[int, typer.Option("--seed", help="Disturbance seed.")] = 1,
    samples: Annotated[int, typer.Option(
        "--samples", help="Parameter samples for the robustness (0: skip).")] = 1000,
    uncertainty_pct: Annotated[float, typer.Option(
        "--uncertainty-pct", help="Relative parameter std [%] where the model file has no "
        "std_errors.")] = 10.0,
    dt: Annotated[float, typer.Option("--dt", help="Integration step [s].")] = 0.02,
    wind_speed: WindSpeedOpt = None,
    wind_dir_deg: WindDirOpt = None,
    current_speed: CurrentSpeedOpt = None,
    current_dir_deg: CurrentDirOpt = None,
    hs: HsOpt = None,
    tp: TpOpt = None,
    wave_dir_deg: WaveDirOpt = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object on stdout.")]
        = False,
) -> None:
    """Heading-autopilot gains from a model: pole placement or ITAE-optimal, with margins."""
    from usvid.commands._physics import check_physics
    from usvid.control import design_autopilot
    from usvid.io.modelfile import load_model

    check_seed(seed)
    check_dt(dt)
    check_number(horizon, "--horizon", lo=0.0, hi=3600.0, lo_open=True, unit="s")
    check_disturbance_deg(disturbance_deg, "--disturbance-deg")
    check_number(samples, "--samples", lo=0, hi=100_000)
    check_number(bandwidth, "--bandwidth", lo=0.0, hi=100.0, lo_open=True, unit="rad/s")
    check_number(zeta, "--zeta", lo=0.0, hi=10.0, lo_open=True)
    check_target_deg(target_deg)
    if abs(target_deg) < 0.1:
        raise UsvidError(f"--target-deg must be at least 0.1 deg in magnitude (got "
                         f"{target_deg!r}): the design is judged on a course change")
    check_number(uncertainty_pct, "--uncertainty-pct", lo=0.0, hi=100.0, unit="%")
    env = environment_of(wind_speed, wind_dir_deg, current_speed, current_dir_deg, hs, tp,
                         wave_dir_deg)
    model = load_model(model_path)
    if getattr(model.vessel, "speed", None) is None:
        raise UsvidError(f"{model_path.name}: vessel.speed is not given (the design needs the "
                         "approach speed)")
    check_speed(model.vessel.speed, f"{model_path.name}: vessel.speed")
    # a model outside a vessel's physics (turning to port under starboard rudder, backing,
    # running away) gets no gains
    check_steps(horizon, dt, "--horizon")
    check_physics(model, model_path, float(model.vessel.speed), dt, strict=True,
                  duration=horizon)
    d = design_autopilot(model, method=method.value, controller=controller.value,
                         bandwidth=bandwidth, zeta=zeta, disturbance_deg=disturbance_deg,
                         horizon=horizon, seed=seed, target_deg=target_deg, dt=dt,
                         samples=samples, uncertainty_pct=uncertainty_pct, environment=env)
    out: dict[str, Any] = {"model": str(model_path), "model_kind": model.kind, **d.to_dict()}
    if as_json:
        from usvid.commands._common import emit_json

        emit_json(out)
        return
    _print(out)


def _print(out: dict[str, Any]) -> None:
    from rich.console import Console
    from rich.table import Table

    h = out["horizon_s"]
    t = Table(title=f"autopilot ({out['method']}, {out['controller']}) for {out['model']}: "
                    f"course change 0 -> {out['target_deg']:g} deg, horizon {h:g} s, "
                    f"disturbance {out['disturbance_deg']:g} deg (seed {out['seed']})")
    t.add_column("")
    t.add_column("kp [rad/rad]", justify="right")
    t.add_column("ki [1/s]", justify="right")
    t.add_column("kd [s]", justify="right")
    t.add_column(f"ITAE over {h:g} s [rad s^2]", justify="right")
    t.add_column("overshoot [deg]", justify="right")
    t.add_column("rudder saturated [s]", justify="right")
    for name, g, s in (("design", out, out["step"]),
                       ("reference", out["reference"], out["reference"]["step"])):
        t.add_row(name, f"{g['kp']:.4g}", f"{g['ki']:.4g}", f"{g['kd']:.4g}",
                  f"{s['itae']:.4g}", f"{s['overshoot_deg']:.3g}", f"{s['saturation_s']:.3g}")
    c = Console()
    c.print(t)
    m = out["margins"]
    c.print(f"margins (linearised loop with servo and dead time): gain {m['gain_margin_db']:.3g}"
            f" dB, phase {m['phase_margin_deg']:.3g} deg at {m['crossover_rad_s']:.3g} rad/s")
    e = out.get("in_environment")
    if e:
        c.print(f"ITAE over {h:g} s (rad s^2) in calm water / in the environment: design "
                f"{e['itae_calm']:.4g} / {e['itae_environment']:.4g}, reference "
                f"{e['reference_itae_calm']:.4g} / {e['reference_itae_environment']:.4g} "
                f"(on {e['heading']})")
    r = out["robustness"]
    if r:
        c.print(f"robustness over {r['samples']} parameter samples (horizon {h:g} s): ITAE "
                f"median {r['itae_median']:.4g}, worst {r['itae_worst']:.4g} rad s^2; worst "
                f"overshoot {r['overshoot_worst_deg']:.3g} deg; smallest margins "
                f"{r['gain_margin_min_db']:.3g} dB, {r['phase_margin_min_deg']:.3g} deg")


def register(app: typer.Typer) -> None:
    """Register ``usvid autopilot`` on the CLI app."""
    app.command("autopilot")(autopilot_cmd)
