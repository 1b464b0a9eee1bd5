"""Model files: round trips, the shipped examples, and one clear error per kind of bad input."""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path

import numpy as np
import pytest

from usvid.errors import ModelFileError, UsvidError
from usvid.io.modelfile import load_model, model_from_dict, model_to_dict, save_model
from usvid.models import Nomoto1, VesselModel, registry

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

NORRBIN = {
    "usvid_model": 1,
    "kind": "norrbin",
    "parameters": {"K": 0.707, "T": 0.332, "n1": 1.0, "n3": 1.102, "delta0": 0.0,
                   "N_delta": None},
    "servo": {"kind": "second_order", "omega_n": 1.3964, "zeta": 0.8526, "gain": 1.0,
              "delay": 1.0, "max_angle_deg": 35.0, "max_rate_deg_s": None},
    "vessel": {"length": 7.02, "speed": 5.144},
    "identification": {"data": ["a.csv"], "method": "rls", "std_errors": {"K": 0.01},
                       "fit": {"rmse_r": 0.02}, "note": "free-form provenance is kept"},
}

THREEDOF = {
    "usvid_model": 1,
    "kind": "threedof",
    "parameters": {"m11": 2652.5, "m22": 2825.6, "m33": 4201.7, "d11": 848.1, "d22": 9889.6,
                   "d33": 22722.0, "x_l": 3.0,
                   "thrust": {"kind": "propeller", "D": 0.46, "pitch_ratio": 0.3,
                              "disk_ratio": 0.516}, "n": 20.0},
    "servo": {"kind": "first_order", "T": 0.5, "max_angle_deg": 35, "max_rate_deg_s": 20},
    "vessel": {"length": 7.02},
}


def test_norrbin_round_trip(tmp_path):
    m = model_from_dict(NORRBIN, "m.json")
    assert m.kind == "norrbin"
    assert m.dynamics.n3 == 1.102
    assert m.servo.delay == 1.0
    assert m.servo.max_angle == pytest.approx(math.radians(35))
    assert math.isinf(m.servo.max_rate)
    assert m.vessel.length == 7.02
    assert m.identification["note"] == "free-form provenance is kept"
    d = model_to_dict(m)
    assert d == NORRBIN  # exactly the schema, no key renamed or added
    p = save_model(m, tmp_path / "sub" / "m.json")
    assert json.loads(p.read_text()) == NORRBIN
    assert model_to_dict(load_model(p)) == NORRBIN


@pytest.mark.parametrize("kind,params", [
    ("nomoto1", {"K": 0.707, "T": 0.332, "delta0": 0.01, "N_delta": None}),
    ("nomoto2", {"K": 0.3, "T1": 20.0, "T2": 2.0, "T3": 4.0, "delta0": 0.0, "N_delta": 5e4}),
])
def test_response_kinds_round_trip(kind, params):
    d = {"usvid_model": 1, "kind": kind, "parameters": params,
         "servo": {"kind": "ideal", "max_angle_deg": 30.0, "max_rate_deg_s": 10.0},
         "vessel": {"length": 3.0, "speed": 1.5, "extra": {"gm": 0.4}}}
    m = model_from_dict(d)
    assert m.kind == kind
    assert m.servo.max_rate == pytest.approx(math.radians(10))
    assert model_to_dict(m) == d


def test_defaults_filled():
    m = model_from_dict({"usvid_model": 1, "kind": "nomoto1", "parameters": {"K": 1, "T": 2}})
    assert m.servo.kind == "ideal" and m.dynamics.delta0 == 0.0
    d = model_to_dict(m)
    assert d["parameters"] == {"K": 1.0, "T": 2.0, "delta0": 0.0, "N_delta": None}
    assert d["servo"] == {"kind": "ideal", "max_angle_deg": 35.0, "max_rate_deg_s": None}


def test_threedof_with_propeller_round_trip():
    m = model_from_dict(THREEDOF, "t.json")
    assert m.kind == "threedof"
    assert type(m.dynamics.thrust).__name__ == "Propeller"
    assert m.dynamics.thrust.D == 0.46
    d = model_to_dict(m)
    assert d["parameters"]["thrust"]["kind"] == "propeller"
    assert model_to_dict(model_from_dict(d)) == d


def test_catamaran_round_trip():
    d = {"usvid_model": 1, "kind": "catamaran",
         "parameters": {"m11": 30.0, "m22": 40.0, "m33": 5.0, "d11": 10.0, "d22": 30.0,
                        "d33": 4.0, "b": 0.5, "thrust": 0.2, "cmd": 60.0, "steer_gain": 50.0}}
    m = model_from_dict(d)
    assert m.kind == "catamaran"
    d2 = model_to_dict(m)
    assert d2["parameters"]["b"] == 0.5
    assert model_to_dict(model_from_dict(d2)) == d2


def _bad(path_and_value):
    d = copy.deepcopy(NORRBIN)
    for keys, value in path_and_value:
        node = d
        for k in keys[:-1]:
            node = node[k]
        if value is KeyError:
            del node[keys[-1]]
        else:
            node[keys[-1]] = value
    return d


@pytest.mark.parametrize("changes,message", [
    ([(("parameters", "T"), -1.2)], "m.json: parameters.T must be > 0 (got -1.2)"),
    ([(("parameters", "T"), KeyError)], "m.json: parameters.T is missing"),
    ([(("parameters", "K"), float("nan"))], "m.json: parameters.K must be a finite number"),
    ([(("parameters", "K"), "0.7")], 'm.json: parameters.K must be a number (got "0.7")'),
    ([(("parameters", "K"), True)], "m.json: parameters.K must be a number"),
    ([(("parameters", "alpha"), 1.1)], "m.json: unknown key parameters.alpha"),
    ([(("kind",), "nomoto3")], "m.json: kind must be one of " + ", ".join(registry.names())
     + " (got \"nomoto3\")"),
    ([(("usvid_model",), 2)], "m.json: usvid_model must be 1"),
    ([(("servo", "kind"), "hydraulic")], "m.json: servo.kind must be one of ideal"),
    ([(("servo", "zeta"), KeyError)], "m.json: servo.zeta is missing"),
    ([(("servo", "delay"), -1.0)], "m.json: servo.delay must be >= 0 (got -1.0)"),
    ([(("servo", "T"), 1.0)], "m.json: unknown key servo.T"),
    ([(("vessel", "length"), 0)], "m.json: vessel.length must be > 0 (got 0)"),
    ([(("vessel", "lenght"), 7.0)], "m.json: unknown key vessel.lenght"),
    ([(("colour",), "red")], "m.json: unknown key colour"),
    ([(("parameters",), [1, 2])], "m.json: parameters must be an object"),
])
def test_bad_fields_name_file_and_field(changes, message):
    with pytest.raises(ModelFileError) as ei:
        model_from_dict(_bad(changes), "m.json")
    assert str(ei.value).startswith(message)
    assert "\n" not in str(ei.value)
    assert isinstance(ei.value, UsvidError)


def test_threedof_bad_nested_thrust():
    d = copy.deepcopy(THREEDOF)
    d["parameters"]["thrust"]["D"] = -0.46
    with pytest.raises(ModelFileError, match=r"t.json: parameters.thrust.D must be > 0"):
        model_from_dict(d, "t.json")
    d["parameters"]["thrust"] = {"kind": "jet"}
    with pytest.raises(ModelFileError, match=r"parameters.thrust.kind must be one of"):
        model_from_dict(d, "t.json")
    d = copy.deepcopy(THREEDOF)
    d["parameters"]["m11"] = -1.0
    with pytest.raises(ModelFileError, match=r"t.json: parameters.m11 must be > 0"):
        model_from_dict(d, "t.json")


def test_load_errors(tmp_path):
    with pytest.raises(ModelFileError, match="not found"):
        load_model(tmp_path / "none.json")
    p = tmp_path / "broken.json"
    p.write_text('{"usvid_model": 1,\n "kind": }')
    with pytest.raises(ModelFileError, match="broken.json line 2 column"):
        load_model(p)
    p = tmp_path / "nan.json"  # the non-JSON NaN literal: reported as a bad field value
    p.write_text(json.dumps(NORRBIN).replace('"T": 0.332', '"T": NaN'))
    with pytest.raises(ModelFileError, match=r"nan.json: parameters.T must be a finite number"):
        load_model(p)
    p.write_text(json.dumps(NORRBIN).replace('"K": 0.707', '"K": -Infinity'))
    with pytest.raises(ModelFileError, match=r"parameters.K must be a finite number"):
        load_model(p)
    p.write_text("[1, 2]")
    with pytest.raises(ModelFileError, match="JSON object"):
        load_model(p)


def test_batch_model_cannot_be_saved():
    with pytest.raises(ModelFileError, match="batch"):
        model_to_dict(VesselModel(Nomoto1(K=np.array([1.0, 2.0]), T=1.0)))


@pytest.mark.parametrize("name", ["lanxin.json", "lanxin_norrbin.json", "lanxin_threedof.json",
                                  "pod_usv.json", "pod_usv_eq25.json", "catamaran.json"])
def test_examples_load(name):
    m = load_model(EXAMPLES / name)
    assert m.vessel.speed is not None and m.vessel.speed > 0
    assert model_to_dict(m)["usvid_model"] == 1
