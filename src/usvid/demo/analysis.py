"""Demo analysis steps that produce report sections: validation of identified models against
measured trials (Mu et al. 2018 figures 7-10), PD vs PID course keeping (Mu et al. 2018 section 6.1,
Table 3) and the Ma et al. turning-diameter fit. Each returns the JSON-able dict stored in
``run.json``.

Units: SI and radians inside; the returned dicts carry degrees where the key says ``_deg``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from usvid.identify.turning_diameter import fit_turning_diameter, load_turning_table
from usvid.manoeuvres.detect import find_execute
from usvid.manoeuvres.imo import (
    imo_turning_applies,
    imo_turning_check,
    imo_zigzag_check,
    zigzag_kind,
)
from usvid.manoeuvres.metrics import turning_metrics, zigzag_metrics
from usvid.models.registry import kind_of
from usvid.models.turning_diameter import relative_turning_diameter
from usvid.sim import PID, CourseChange, Disturbance, Turning, ZigZag, simulate

#: Samples per second kept for the figures in run.json (the logs are 50 Hz).
PLOT_RATE_HZ = 5.0




def _decimate(t: np.ndarray, arrays: dict[str, np.ndarray]) -> tuple[list, dict[str, list]]:
    step = max(int(round(1.0 / (PLOT_RATE_HZ * float(np.median(np.diff(t)))))), 1)
    return (np.round(t[::step], 3).tolist(),
            {k: [None if not np.isfinite(v) else round(float(v), 5) for v in a[::step]]
             for k, a in arrays.items()})


def validate_against(model: Any, trial: Any, manoeuvre: Any, model_kind: str,
                     camp: Any) -> dict[str, Any]:
    """Simulate the identified model through the trial's manoeuvre and compare.

    The simulation starts from the measured initial heading and speed; zig-zag and turning use
    the same logic as the trial (``ZigZag``/``Turning`` with the identified servo), started at
    the execute of the measured command and to its side
    (:func:`usvid.manoeuvres.detect.find_execute` on ``delta_cmd``); the measured and the
    simulated manoeuvre metrics are both taken from that execute. For a 3-DOF model the
    thrust is the propeller at the measured mean shaft speed. Returns the ``run.json``
    validation entry: decimated time series (x, y [m]; psi, r, delta in deg, deg/s, deg; u, v
    [m/s]), measured and simulated manoeuvre metrics, IMO criteria of the measured trial, RMS
    errors.
    """

    t = trial.t
    L = float(camp.vessel["length"])
    amp = math.radians(manoeuvre.delta_deg)
    t_exec, to_side = find_execute(t, trial["delta_cmd"])
    t_exec -= float(t[0])
    psi_meas = trial["psi"].copy()
    ok = np.isfinite(psi_meas)
    psi_meas[ok] = np.unwrap(psi_meas[ok])  # (prep already unwraps; NaN-safe either way)
    fin = psi_meas[np.isfinite(psi_meas)]
    if fin.size:  # start within (-180, 180] deg, as the simulation does
        psi_meas = psi_meas - 2.0 * math.pi * round(float(fin[0]) / (2.0 * math.pi))
    u_meas = trial["U"] if trial.has("U") else trial["u"]
    first = slice(0, max(int(1.0 / float(np.median(np.diff(t)))), 2))
    psi0 = float(np.nanmean(psi_meas[first]))
    u0 = float(np.nanmean(u_meas[first]))
    if manoeuvre.kind == "zigzag":
        logic: Any = ZigZag(amp, math.radians(manoeuvre.psi_deg), first=to_side, t_start=t_exec)
    else:
        logic = Turning(to_side * amp, t_start=t_exec)
    duration = float(t[-1] - t[0])
    res = simulate(model, logic, t_end=duration, dt=0.02, u0=u0, psi0=psi0)
    ts = np.asarray(res.t) + float(t[0])
    ch = {k: np.asarray(v)[0] for k, v in res.channels.items()}
    sim_x = ch["x"] + float(np.nanmean(trial["x"][first]))
    sim_y = ch["y"] + float(np.nanmean(trial["y"][first]))

    def on_meas(a: np.ndarray) -> np.ndarray:
        return np.interp(t, ts, a)

    meas = {"x": trial["x"], "y": trial["y"], "psi": np.degrees(psi_meas),
            "r": np.degrees(trial["r"]), "delta": np.degrees(trial["delta"]),
            "u": trial["u"] if trial.has("u") else None,
            "v": trial["v"] if trial.has("v") else None}
    sim = {"x": on_meas(sim_x), "y": on_meas(sim_y), "psi": np.degrees(on_meas(ch["psi"])),
           "r": np.degrees(on_meas(ch["r"])), "delta": np.degrees(on_meas(ch["delta"])),
           "u": on_meas(ch["u"]) if "u" in ch else None,
           "v": on_meas(ch["v"]) if "v" in ch else None}
    arrays = {}
    for k in ("x", "y", "psi", "r", "delta", "u", "v"):
        for side, src in (("m", meas), ("s", sim)):
            if src[k] is not None:
                arrays[f"{side}_{k}"] = np.asarray(src[k], float)
    tt, dec = _decimate(t, arrays)
    labels = {"psi": "psi [deg]", "r": "r [deg/s]", "delta": "delta [deg]", "u": "u [m/s]",
              "v": "v [m/s]"}
    channels = []
    for k in ("psi", "r", "delta", "u", "v"):
        if kind_of(model.dynamics).constant_speed and k in ("u", "v"):
            continue
        lines = {}
        if f"m_{k}" in dec:
            lines["measured"] = dec[f"m_{k}"]
        if f"s_{k}" in dec:
            lines["simulated"] = dec[f"s_{k}"]
        if lines:
            channels.append({"name": k, "ylabel": labels[k], "lines": lines})
    entry: dict[str, Any] = {
        "trial": trial.name, "model": model_kind, "t": tt,
        "xy": {"measured": {"x": dec["m_x"], "y": dec["m_y"]},
               "simulated": {"x": dec["s_x"], "y": dec["s_y"]}},
        "channels": channels,
    }
    fit = {}
    for k in ("psi", "r"):
        e = sim[k] - meas[k]
        fit[f"rms_{k}_err"] = float(np.sqrt(np.nanmean(e ** 2)))
    entry["fit"] = {"psi RMS error [deg]": fit["rms_psi_err"],
                    "r RMS error [deg/s]": fit["rms_r_err"]}
    U = float(camp.vessel["speed"])
    try:
        # both measured from the execute of the measured order, where the simulation starts
        t_e = t_exec + float(t[0])
        if manoeuvre.kind == "zigzag":
            sw = math.radians(manoeuvre.psi_deg)
            mm = zigzag_metrics(t, psi_meas, trial["delta"], delta_amp=amp, psi_switch=sw,
                                t_execute=t_e, first=to_side)
            ms = zigzag_metrics(ts, ch["psi"], ch["delta"], delta_amp=amp, psi_switch=sw,
                                t_execute=t_e, first=to_side)
            kind = zigzag_kind(manoeuvre.delta_deg, manoeuvre.psi_deg)
            if kind:
                entry["imo"] = [c.to_dict() for c in imo_zigzag_check(mm, L, U, kind).criteria]
        else:
            mm = turning_metrics(t, trial["x"], trial["y"], psi_meas, U=u_meas, r=trial["r"],
                                 t_execute=t_e)
            ms = turning_metrics(ts, sim_x, sim_y, ch["psi"], U=ch.get("U"), r=ch["r"],
                                 t_execute=t_e)
            if imo_turning_applies(amp, float(model.servo.max_angle)):
                entry["imo"] = [c.to_dict() for c in imo_turning_check(mm, L).criteria]
        entry["metrics"] = {"measured": mm.to_dict(), "simulated": ms.to_dict()}
    except Exception as exc:  # metrics of a short/odd record: say so in the report
        entry["metrics_error"] = f"{type(exc).__name__}: {exc}"
    return entry


def course_keeping(model: Any, camp: Any, *, seed: int,
                   gains: dict[str, tuple[float, float, float]], target_deg: float = 100.0,
                   dist_deg: float = 2.0, t_end: float = 100.0) -> dict[str, Any]:
    """PD vs PID course change 0 -> ``target_deg`` on the identified model under the Mu et al. 2018
    disturbance (white noise through 0.42 s/(s^2 + 0.36 s + 0.37), std ``dist_deg``
    rudder-equivalent), the same disturbance realisation for every controller.

    Returns the ``run.json`` course_keeping entry (decimated psi, delta [deg], disturbance
    [deg], ITAE [rad s^2], IAE [rad s], max rudder [deg] per controller).
    """

    dist = Disturbance(math.radians(dist_deg), seed=seed)
    runs, t, d = [], None, None
    for label, (kp, ki, kd) in gains.items():
        res = simulate(model, CourseChange(math.radians(target_deg), PID(kp, ki, kd), dist),
                       t_end=t_end, dt=0.02, u0=float(camp.vessel["speed"]))
        t = np.asarray(res.t)
        arrays = {"psi": np.degrees(np.asarray(res.channels["psi"])[0]),
                  "delta": np.degrees(np.asarray(res.channels["delta"])[0])}
        if "dist" in res.channels:
            arrays["dist"] = np.degrees(np.asarray(res.channels["dist"])[0])
        tt, dec = _decimate(t, arrays)
        d = dec.get("dist", d)
        m = res.course_metrics()[0]
        runs.append({"label": label, "kp": kp, "ki": ki, "kd": kd, "psi_deg": dec["psi"],
                     "delta_deg": dec["delta"], "itae": m["itae"], "iae": m["iae"],
                     "max_rudder_deg": m["max_rudder_deg"]})
    out = {
        "description": (
            f"Identified Norrbin model with the identified servo, course change 0 -> "
            f"{target_deg:g} deg, disturbance std {dist_deg:g} deg (rudder-equivalent, seed "
            f"{seed}); PID gains of Mu et al. 2018, section 6.1 (error in rad, delta in rad). "
            f"ITAE = int_0^H t |psi_d - psi| dt in rad s^2 over the horizon H = {t_end:g} s "
            "(the run is 0 .. H); Mu et al. 2018 do not state their units, horizon or "
            "disturbance intensity, so their Table 3 values are shown for orientation only."),
        "t": tt, "target_deg": target_deg, "runs": runs,
    }
    if d is not None:
        out["disturbance"] = d
    return out


def turning_diameter_fit(seed: int = 0, quick: bool = False) -> dict[str, Any]:
    """Ma et al. eq. 1 fitted to Ma et al. Table 2 by the chaotic GA (Ma et al.'s settings; fewer
    generations when ``quick``), next to the published eq. 3. Returns the ``run.json`` entry."""

    Fr, delta, DL = load_turning_table(None)
    opts = {"generations": 150} if quick else None
    fits = fit_turning_diameter(Fr, delta, DL, methods=("cga", "published_eq3"), seed=seed,
                                loo=False, cga_options=opts)
    cga, pub = fits["cga"], fits["published_eq3"]
    a = cga.coeffs.as_array()
    Fr_mid = float(np.median(Fr))
    dd = np.radians(np.linspace(max(np.degrees(delta.min()) - 2, 1.0),
                                np.degrees(delta.max()) + 2, 60))
    sel = np.isclose(Fr, Fr_mid, rtol=0.05)
    return {
        "description": (
            "Relative turning diameter D/L = a1 (Fr + a2 Fr^2 + a3 Fr^3)/(delta^a4 + a5 delta) "
            f"(Ma et al. eq. 1) fitted to the {Fr.size} turning tests of Ma et al. Table 2 by the "
            "chaotic genetic algorithm (Ma et al. settings), RMS objective eq. 2. The figure "
            f"shows the tests with Fr within 5 % of {Fr_mid:.3f} and the fitted curve there."),
        "points_delta_deg": np.degrees(delta[sel]).tolist(),
        "points_D_over_L": DL[sel].tolist(),
        "curve_delta_deg": np.degrees(dd).tolist(),
        "curve_D_over_L": np.asarray(relative_turning_diameter(Fr_mid, dd, a)).tolist(),
        "coeffs": dict(zip(("a1", "a2", "a3", "a4", "a5"), a.tolist(), strict=True)),
        "coeffs_published": dict(zip(("a1", "a2", "a3", "a4", "a5"),
                                     pub.coeffs.as_array().tolist(), strict=True)),
        "rms": cga.F, "rms_published": pub.F, "n": int(Fr.size),
    }
