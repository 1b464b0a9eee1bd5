"""CLI: ``usvid montecarlo MODEL.json --manoeuvre zigzag|turning|course-keeping [options]
--runs N [--from-uncertainty] [--vary NAME=normal:MEAN,SD ...] [--seed S] [--disturbance-deg SD]
[--wind-speed V|DIST] [--wind-dir-deg D|DIST] [--current-speed V|DIST]
[--current-dir-deg D|DIST] [--hs H|DIST --tp T|DIST [--wave-dir-deg D|DIST]]
--out RESULTS.parquet [--scheduler ADDRESS] [--workers N] [--json]``.

Samples the model's parameters (:mod:`usvid.scale.montecarlo`), simulates the runs in chunks in
this process on a small machine, else on a Dask cluster (a local one, or the scheduler at
``--scheduler``; :func:`usvid.scale.montecarlo.use_dask`), writes one row per run (sampled
parameters [SI], ``success``, metrics) to a Parquet file atomically and prints the quantiles of
each metric; with ``--json`` one object: ``out``, ``runs``, ``failed``, ``parameters``,
``uncertainty`` (where the joint draws come from), ``seed``, ``disturbance_deg``, ``quantiles``
(per metric ``q05``, ``q50``, ``q95``, ``mean``, ``n``), ``chunks``, ``chunk`` (runs per task),
``redrawn`` (runs whose first draw was outside the parameter bounds, drawn again),
``failed_draws`` (runs with no valid draw; their rows have ``success`` false), ``sea_redrawn``
(runs whose sea state drawn per run was drawn again: a height or period at or below 0),
``diverged``,
``workers`` (processes, or the kernel's threads in process), ``backend`` (``in-process`` |
``dask``), ``wall_s``, ``environment`` (null in calm water; else per option its value or its
distribution ``{"dist", "a", "b"}`` in the option's units, and the environment of run 0 as
``usvid simulate`` describes it: ``run0``). The environment options are those of ``usvid
simulate`` (:func:`usvid.commands._common.environment_of` checks them); each also takes
``normal:MEAN,SD`` or ``uniform:LO,HI`` (the form of ``--vary``, in the option's units), drawn
per run. Something must differ between the runs: drawn parameters (``--from-uncertainty``,
``--vary``), an environment drawn per run, a sea state (each run its own realisation of the
waves) or ``--disturbance-deg`` (each run its own noise). Every option is checked before any
work; the output may not be the model file (nor a device node).
"""

from __future__ import annotations

import dataclasses
import io
import time
from pathlib import Path
from typing import Annotated, Any

import typer

from usvid.commands._common import (
    SchedulerOpt,
    WorkersOpt,
    check_seed,
    emit_json,
)
from usvid.errors import UsvidError
from usvid.files import write_atomic

ManoeuvreOpt = Annotated[str, typer.Option(
    "--manoeuvre", help="zigzag, turning or course-keeping.")]


def check_options(manoeuvre: str, options: dict[str, Any]) -> None:
    """The manoeuvre options of ``usvid montecarlo`` at the edge, each error naming its
    option (the ranges of ``usvid simulate``)."""
    from usvid.commands._common import (
        check_disturbance_deg,
        check_dt,
        check_gain,
        check_psi_deg,
        check_rudder_deg,
        check_speed,
        check_t_end,
        check_target_deg,
    )

    o = options
    check_rudder_deg(o.get("delta_deg"), signed=manoeuvre == "turning")
    check_psi_deg(o.get("psi_deg"))
    check_target_deg(o.get("target_deg"))
    for k in ("kp", "ki", "kd"):
        check_gain(o.get(k), f"--{k}")
    check_t_end(o.get("t_end"))
    check_dt(o.get("dt", 0.02))
    check_speed(o.get("speed"))
    check_disturbance_deg(o.get("disturbance_deg"), "--disturbance-deg")


def environment_options(values: dict[str, str | float | None]) -> dict[str, Any]:
    """The environment options of ``usvid montecarlo`` (name -> the text given, or None) ->
    name -> a number or a distribution (:func:`usvid.scale.montecarlo.parse_environment`),
    checked by :func:`usvid.commands._common.environment_of` on the number, or on the mean
    (normal) and both ends (uniform) of the distribution."""
    from usvid.commands._common import environment_of
    from usvid.scale.montecarlo import ENVIRONMENT, parse_environment

    out: dict[str, Any] = {}
    for name in ENVIRONMENT:
        v = values.get(name)
        if v is not None:
            out[name] = parse_environment(str(v), name)
    ends = ({"a"}, {"a", "b"})
    for end in ("a", "b"):
        probe = {n: (v if isinstance(v, float) else
                     (getattr(v, end) if end in ends[v.dist == "uniform"] else v.a))
                 for n, v in out.items()}
        environment_of(**probe)
    return out


def _environment_json(mc: Any) -> dict[str, Any] | None:
    """The ``environment`` key: the options as given, and run 0's environment described."""
    if not mc.environment:
        return None
    import numpy as np

    from usvid.scale.montecarlo import Distribution

    given = {n: ({"dist": v.dist, "a": v.a, "b": v.b} if isinstance(v, Distribution)
                 else float(v)) for n, v in mc.environment.items()}
    from usvid.io.modelfile import model_from_dict

    e0 = mc.environment_of(0, 1)
    env0 = dataclasses.replace(e0, **{k: float(np.asarray(getattr(e0, k))[0]) for k in (
        "current_speed", "current_dir", "wind_speed", "wind_dir")},
        sea=None if e0.sea is None else e0.sea.lane(0))
    # (checks the particulars the loads need before any run)
    return {**given, "run0": env0.describe_for(model_from_dict(mc.model))}


def montecarlo(model_path: Path, manoeuvre: str, runs: int, out: Path, *,
               from_uncertainty: bool = False, vary: list[str] | None = None, seed: int = 0,
               options: dict[str, Any] | None = None, scheduler: str | None = None,
               workers: int | None = None, chunk: int = 4096, client: Any = None,
               progress: bool = True, environment: dict[str, Any] | None = None
               ) -> dict[str, Any]:
    """Everything ``usvid montecarlo`` does; returns its JSON object (and writes ``out``).
    ``environment``: option name -> text or number (:func:`environment_options`).
    ``client``: an existing Dask client; else the runs stay in this process on a small machine
    (:func:`usvid.scale.montecarlo.use_dask`) or go to a cluster from ``scheduler``/``workers``.
    """
    import numpy as np  # (here: `usvid --help` loads no numpy)

    from usvid.commands._common import check_steps
    from usvid.commands._physics import check_physics
    from usvid.files import check_outputs
    from usvid.io.modelfile import load_model, model_to_dict
    from usvid.models.uncertainty import Uncertainty
    from usvid.scale.cluster import check_scheduler_address, check_workers, connect, cores
    from usvid.scale.montecarlo import (
        Distribution,
        MonteCarlo,
        check_size,
        parse_vary,
        quantiles,
        run_montecarlo,
        run_timing,
        use_dask,
    )

    check_outputs([out], [model_path])  # before any work: never over the model file
    options = dict(options or {})
    check_options(manoeuvre, options)
    env = environment_options(dict(environment or {}))
    if scheduler:
        check_scheduler_address(scheduler)
    check_workers(workers)
    vm = load_model(model_path)  # validated (the uncertainty blocks too), errors naming the file
    model = model_to_dict(vm)
    names: list[str] = []
    mean, cov, source = np.zeros(0), np.zeros((0, 0)), "none"
    if from_uncertainty:
        unc = Uncertainty.from_model(vm, source=Path(model_path).name)
        if not unc.names:
            raise UsvidError(f"{model_path}: --from-uncertainty needs identification.covariance "
                             "or identification.std_errors in the model file (an identified "
                             "model)")
        names, mean, cov, source = list(unc.names), unc.mean, unc.cov, unc.source
    varies = tuple(parse_vary(v) for v in vary or [])
    # each run its own: drawn environment, wave realisation (a sea state), disturbance noise
    random_runs = (any(isinstance(v, Distribution) for v in env.values()) or "hs" in env
                   or float(options.get("disturbance_deg", 0.0)) > 0)
    if not names and not varies and not random_runs:
        raise UsvidError("montecarlo: nothing to vary: give --from-uncertainty and/or --vary, "
                         "an environment option as a distribution, a sea state (--hs, --tp) "
                         "or --disturbance-deg")
    mc = MonteCarlo(model, manoeuvre, options, tuple(names), mean, cov, varies, int(seed), env)
    u0, dt, run = run_timing(mc, vm)
    check_steps(run, dt, "--t-end" if "t_end" in options else f"the run ({run:g} s, from the "
                "model; --t-end)")
    # the model file itself within its kind's physics (its draws may stray: their metrics are
    # then NaN, counted out of the quantiles' n)
    check_physics(vm, model_path, u0, dt, duration=run)
    env_json = _environment_json(mc)  # (and the vessel's particulars the loads need, checked)
    chunk = check_size(mc, runs, chunk)
    t0 = time.perf_counter()
    backend = "dask"
    if client is not None:
        df = run_montecarlo(mc, runs, chunk=chunk, client=client, progress=progress)
        nworkers = len(client.scheduler_info().get("workers", {}))
    elif not use_dask(scheduler, workers, cores()):
        nworkers = workers or cores()
        backend = "in-process"
        df = run_montecarlo(mc, runs, chunk=chunk, threads=nworkers)
    else:
        with connect(scheduler, workers) as cl:
            df = run_montecarlo(mc, runs, chunk=chunk, client=cl, progress=progress)
            nworkers = len(cl.scheduler_info().get("workers", {}))
    q = quantiles(df, mc.metrics)
    if not any(v["n"] for v in q.values()):
        ok = int(df["success"].sum())
        rudder = "" if manoeuvre == "course-keeping" else " or a larger --delta-deg"
        raise UsvidError(f"montecarlo: no run gave a {manoeuvre} metric ({ok} of {runs} ran to "
                         f"the end of {run:g} s without diverging; the manoeuvre did not "
                         f"complete): give a longer --t-end{rudder}, or check the model and "
                         "--speed")
    buf = io.BytesIO()
    df.to_parquet(buf, index=False)
    write_atomic(out, buf.getvalue(), inputs=[model_path])
    valid = df["valid_draw"].to_numpy(bool)
    return {"out": str(out), "runs": int(runs), "failed": int((~df["success"]).sum()),
            "redrawn": int(((df["redraws"].to_numpy() > 0) & valid).sum()),
            "failed_draws": int((~valid).sum()),
            "sea_redrawn": int((df["sea_redraws"].to_numpy() > 0).sum())
            if "sea_redraws" in df else 0,
            "diverged": int((valid & ~df["success"].to_numpy(bool)).sum()),
            "manoeuvre": manoeuvre, "parameters": list(mc.parameters), "uncertainty": source,
            "seed": int(seed), "disturbance_deg": float(mc.options.get("disturbance_deg", 0.0)),
            "quantiles": q, "chunks": -(-runs // chunk), "chunk": int(chunk), "workers": nworkers,
            "backend": backend, "wall_s": round(time.perf_counter() - t0, 3),
            "environment": env_json}


def _print(s: dict[str, Any]) -> None:
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"montecarlo {s['manoeuvre']}: {s['runs']} runs ({s['diverged']} "
                        f"diverged, {s['redrawn']} draws redrawn within the parameter bounds, "
                        f"{s['failed_draws']} failed) -> {s['out']}")
    for col in ("metric", "q05", "q50", "q95", "mean", "n"):
        table.add_column(col, justify="left" if col == "metric" else "right")
    for m, q in s["quantiles"].items():
        table.add_row(m, *("-" if q[k] is None else f"{q[k]:.4g}"
                           for k in ("q05", "q50", "q95", "mean")), str(q["n"]))
    Console().print(table)
    if s.get("environment"):
        given = {k: v for k, v in s["environment"].items() if k != "run0"}
        Console().print("environment: " + ", ".join(
            f"{k} {v['dist']}:{v['a']:g},{v['b']:g}" if isinstance(v, dict) else f"{k} {v:g}"
            for k, v in given.items()))


def register(app: typer.Typer) -> None:
    @app.command("montecarlo")
    def montecarlo_cmd(
        model_path: Annotated[Path, typer.Argument(help="Model file (JSON, usvid_model: 1).",
                                                   show_default=False)],
        manoeuvre: ManoeuvreOpt,
        out: Annotated[Path, typer.Option("--out", help="Results (Parquet, one row per run).")],
        runs: Annotated[int, typer.Option("--runs", help="Number of runs.")] = 1000,
        from_uncertainty: Annotated[bool, typer.Option(
            "--from-uncertainty", help="Draw the fitted parameters from the model file's "
            "covariance (or its standard errors).")] = False,
        vary: Annotated[list[str] | None, typer.Option(
            "--vary", help="NAME=normal:MEAN,SD or NAME=uniform:LO,HI (SI units); repeat for "
            "several.")] = None,
        seed: Annotated[int, typer.Option("--seed", help="Random seed.")] = 0,
        delta_deg: Annotated[float | None, typer.Option(
            "--delta-deg", help="Rudder amplitude / angle [deg] (zig-zag 10, turning 35).")]
            = None,
        psi_deg: Annotated[float | None, typer.Option(
            "--psi-deg", help="Zig-zag switching heading [deg] (default --delta-deg).")] = None,
        target_deg: Annotated[float, typer.Option(
            "--target-deg", help="Course change [deg] (course-keeping).")] = 100.0,
        kp: Annotated[float, typer.Option("--kp", help="Autopilot gain [rad/rad].")] = 0.7,
        ki: Annotated[float, typer.Option("--ki", help="Integral gain [1/s].")] = 0.0,
        kd: Annotated[float, typer.Option("--kd", help="Derivative gain [s].")] = 1.0,
        t_end: Annotated[float | None, typer.Option(
            "--t-end", help="Simulated time per run [s].")] = None,
        dt: Annotated[float, typer.Option("--dt", help="Integration step [s].")] = 0.02,
        speed: Annotated[float | None, typer.Option(
            "--speed", help="Approach speed [m/s] (default: the model's vessel.speed).")] = None,
        disturbance_deg: Annotated[float, typer.Option(
            "--disturbance-deg", help="Disturbance std [deg] (Mu et al. 2018 filter; run i's "
            "noise seeded by (--seed, i)); 0 = calm.")] = 0.0,
        chunk: Annotated[int, typer.Option("--chunk", help="Runs per Dask task.")] = 4096,
        wind_speed: Annotated[str | None, typer.Option(
            "--wind-speed", help="True wind speed [m/s], or normal:MEAN,SD / uniform:LO,HI "
            "drawn per run (default: calm).")] = None,
        wind_dir_deg: Annotated[str | None, typer.Option(
            "--wind-dir-deg", help="Direction the true wind comes FROM [deg, clockwise from "
            "north], or a distribution.")] = None,
        current_speed: Annotated[str | None, typer.Option(
            "--current-speed", help="Current speed [m/s], or a distribution.")] = None,
        current_dir_deg: Annotated[str | None, typer.Option(
            "--current-dir-deg", help="Direction the current flows TOWARDS [deg, clockwise "
            "from north], or a distribution.")] = None,
        hs: Annotated[str | None, typer.Option(
            "--hs", help="Significant wave height [m] of a JONSWAP sea (with --tp), or a "
            "distribution (a draw <= 0 is drawn again); default: none.")] = None,
        tp: Annotated[str | None, typer.Option(
            "--tp", help="Peak wave period [s] (with --hs), or a distribution (a draw <= 0 "
            "is drawn again).")] = None,
        wave_dir_deg: Annotated[str | None, typer.Option(
            "--wave-dir-deg", help="Direction the waves come FROM [deg, clockwise from "
            "north], or a distribution.")] = None,
        scheduler: SchedulerOpt = None,
        workers: WorkersOpt = None,
        as_json: Annotated[bool, typer.Option("--json", help="Print one JSON object.")] = False,
    ) -> None:
        """Monte-Carlo simulation of a manoeuvre over parameter uncertainty (Dask)."""
        check_seed(seed)
        opts = {k: v for k, v in dict(delta_deg=delta_deg, psi_deg=psi_deg,
                                      target_deg=target_deg, kp=kp, ki=ki, kd=kd, t_end=t_end,
                                      dt=dt, speed=speed,
                                      disturbance_deg=disturbance_deg).items() if v is not None}
        s = montecarlo(model_path, manoeuvre, runs, out, from_uncertainty=from_uncertainty,
                       vary=vary, seed=seed, options=opts, scheduler=scheduler,
                       workers=workers, chunk=chunk, progress=not as_json,
                       environment=dict(wind_speed=wind_speed, wind_dir_deg=wind_dir_deg,
                                        current_speed=current_speed,
                                        current_dir_deg=current_dir_deg, hs=hs, tp=tp,
                                        wave_dir_deg=wave_dir_deg))
        if as_json:
            emit_json(s)
        else:
            _print(s)
