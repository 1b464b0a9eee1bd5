"""Trial format specs: schema validation with errors that name the file and the field."""

from __future__ import annotations

import math

import pytest

from usvid.errors import FormatSpecError, UsvidError
from usvid.io import load_spec, parse_spec, shipped_spec, shipped_specs
from usvid.io.units import UNITS, canonical_unit, target_factor

BASE = {"reader": "table", "columns": {"t": {"col": 0, "unit": "s"}}}


def spec_with(**cols):
    return {"reader": "table", "columns": {"t": {"col": 0, "unit": "s"}, **cols}}


def test_minimal_spec_defaults():
    s = parse_spec(BASE, "m.yaml")
    assert s.reader == "table" and s.delimiter is None and s.skip_rows == 0
    assert s.columns["t"].col == 0 and s.columns["t"].unit == "s"
    assert s.encoding == "utf-8" and s.non_monotonic == "sort"


@pytest.mark.parametrize(
    "unit, value, channel, expected",
    [
        # hand values: 1 kn = 1852/3600 m/s; 600 rpm = 10 rps; 90 deg = pi/2 rad; 1500 ms = 1.5 s
        ("kn", 1.0, "U", 1852.0 / 3600.0),
        ("rpm", 600.0, "n", 10.0),
        ("deg", 90.0, "psi", math.pi / 2),
        ("deg/s", 180.0, "r", math.pi),
        ("ms", 1500.0, "t", 1.5),
        ("km", 2.5, "x", 2500.0),
        ("km/h", 36.0, "u", 10.0),
        ("kN*m", 2.0, "tau_r", 2000.0),
        ("rad", 1.0, "lat", 180.0 / math.pi),  # lat/lon stay in degrees (Trial contract)
        ("deg", 54.5, "lon", 54.5),
    ],
)
def test_unit_factors(unit, value, channel, expected):
    assert target_factor(channel, unit) * value == pytest.approx(expected, rel=1e-12)


def test_sign_scale_offset_order():
    # value = sign * factor * (scale * raw + offset): 10 * 2 + 5 = 25 deg, negated, in rad
    s = parse_spec(
        spec_with(delta={"col": 1, "unit": "deg", "sign": -1, "scale": 2.0, "offset": 5.0})
    )
    assert s.columns["delta"].convert(10.0) == pytest.approx(-math.radians(25.0), rel=1e-12)


def test_every_unit_has_a_known_dimension():
    assert {"s", "ms", "m", "km", "deg", "rad", "deg/s", "rad/s", "m/s", "kn", "rps", "rpm",
            "N", "N*m"} <= set(UNITS)
    assert canonical_unit("knots") == "kn" and canonical_unit("Nm") == "N*m"
    assert canonical_unit("furlong") is None


def test_unknown_top_level_key_named():
    with pytest.raises(FormatSpecError, match=r"m\.yaml: delimeter: unknown key 'delimeter'"):
        parse_spec({**BASE, "delimeter": ","}, "m.yaml")


def test_unknown_column_key_named():
    with pytest.raises(FormatSpecError, match=r"columns\.psi\.units: unknown key 'units'"):
        parse_spec(spec_with(psi={"col": 3, "units": "deg"}), "m.yaml")


def test_unknown_unit_named():
    with pytest.raises(FormatSpecError, match=r"m\.yaml: columns\.psi\.unit: unknown unit 'degs'"):
        parse_spec(spec_with(psi={"col": 3, "unit": "degs"}), "m.yaml")


def test_unit_of_wrong_dimension():
    with pytest.raises(FormatSpecError, match=r"columns\.psi\.unit: unit 'm/s' is a speed"):
        parse_spec(spec_with(psi={"col": 3, "unit": "m/s"}), "m.yaml")


@pytest.mark.parametrize(
    "d, pattern",
    [
        ({"columns": {"t": 0}}, r"reader: missing"),
        ({"reader": "csv"}, r"reader: unknown reader 'csv'"),
        ({"reader": "table", "columns": {"x": {"col": 1, "unit": "m"}}}, r"columns\.t: missing"),
        (spec_with(x={"col": 1}), r"columns\.x\.unit: missing"),
        (spec_with(x={"col": -1, "unit": "m"}), r"columns\.x\.col: column index must be >= 0"),
        (spec_with(x={"col": 1.5, "unit": "m"}), r"columns\.x\.col: expected an index"),
        (spec_with(delta={"col": 1, "unit": "deg", "sign": 2}), r"columns\.delta\.sign: must be"),
        ({**BASE, "delimiter": "|"}, r"delimiter: expected whitespace"),
        ({**BASE, "skip_rows": -1}, r"skip_rows: expected an integer >= 0"),
        ({**BASE, "encoding": "klingon"}, r"encoding: unknown text encoding"),
        ({**BASE, "sheet": "Sheet1"}, r"sheet: only used by reader excel"),
        ({**BASE, "vessel": {"length": -7}}, r"vessel\.length: must be > 0"),
        ({**BASE, "vessel": {"lenght": 7}}, r"vessel\.lenght: unknown key"),
        ({**BASE, "non_monotonic": "ignore"}, r"non_monotonic: expected 'sort' or 'reject'"),
        ([1, 2], r"must be a mapping"),
    ],
)
def test_schema_errors(d, pattern):
    with pytest.raises(FormatSpecError, match=pattern):
        parse_spec(d, "m.yaml")


def test_load_spec_yaml_file(tmp_path):
    p = tmp_path / "s.yaml"
    p.write_text(
        "reader: table\ndelimiter: ','\nheader: true\ncolumns:\n"
        "  t: {col: time, unit: s}\n  psi: {col: hdg, unit: deg}\nvessel: {length: 7.0}\n"
    )
    s = load_spec(p)
    assert s.columns["psi"].col == "hdg" and s.vessel.length == 7.0 and s.source == "s.yaml"


def test_load_spec_rejects_python_tags(tmp_path):
    # yaml.safe_load only: an object constructor tag is an error, never evaluated
    p = tmp_path / "evil.yaml"
    p.write_text("reader: !!python/object/apply:os.system ['echo hacked']\n")
    with pytest.raises(FormatSpecError, match="evil.yaml"):
        load_spec(p)


def test_load_spec_bad_yaml_and_missing_file(tmp_path):
    p = tmp_path / "bad.yaml"
    p.write_text("reader: [table\n")
    with pytest.raises(FormatSpecError, match=r"bad\.yaml"):
        load_spec(p)
    with pytest.raises(FormatSpecError, match="cannot read"):
        load_spec(tmp_path / "nope.yaml")


def test_nmea_spec_renames_only():
    s = parse_spec({"reader": "nmea0183", "columns": {"delta": {"col": "delta", "sign": -1}}})
    assert s.columns["delta"].sign == -1
    with pytest.raises(FormatSpecError, match="delivers 'psi' in rad"):
        parse_spec({"reader": "nmea0183", "columns": {"psi": {"col": "psi", "unit": "deg"}}})


def test_shipped_specs_all_load():
    names = shipped_specs()
    assert {"hsva_kvlcc2", "hsva_kvlcc2_catalogue", "twin_thruster_xlsx"} <= set(names)
    assert {"ros2_usv", "px4_boat", "ardupilot_rover", "ardupilot_skid_steer"} <= set(names)
    for n in names:
        assert shipped_spec(n).reader in ("table", "excel", "rosbag", "ulog", "dataflash")
    with pytest.raises(UsvidError, match="no shipped format spec"):
        shipped_spec("nope")


def test_shipped_hsva_conventions():
    s = shipped_spec("hsva_kvlcc2")
    assert s.columns["r"].col == 6 and s.columns["delta"].sign == -1
    assert "v" not in s.columns  # no column of the file is the sway velocity
    c = shipped_spec("hsva_kvlcc2_catalogue")
    assert c.columns["r"].col == 7 and c.columns["delta"].sign == 1
