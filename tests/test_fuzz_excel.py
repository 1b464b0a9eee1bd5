"""Fuzzing (``fuzz`` marker): the Excel reader on workbooks whose sheet XML is mutated (cells,
types, row and column references, hostile values) and on byte mutations of the .xlsx itself
only returns a Trial honouring the contract or raises a UsvidError. See tests/fuzzing.py."""

from __future__ import annotations

import io
import random
import zipfile

import pytest

from fuzzing import binary_mutate, check_trial, fuzz, halves, mutate, put, safe
from usvid.io import read_excel
from usvid.io.spec import parse_spec

openpyxl = pytest.importorskip("openpyxl")
pytestmark = pytest.mark.fuzz
SPEC = parse_spec({"reader": "excel", "columns": {"t": {"col": "t", "unit": "s"},
                                                  "psi": {"col": "psi", "unit": "deg"}}})
SPEC_SKIP = parse_spec({"reader": "excel", "skip_rows": 1, "header": False, "sheet": "Sheet",
                        "columns": {"t": {"col": 0, "unit": "s"}, "r": {"col": 1,
                                                                        "unit": "deg/s"}}})


def _workbook() -> dict[str, bytes]:
    wb = openpyxl.Workbook()
    sh = wb.active
    sh.append(["t", "psi"])
    for i in range(4):
        sh.append([i * 0.1, 10.0 * i])
    buf = io.BytesIO()
    wb.save(buf)
    with zipfile.ZipFile(buf) as z:
        return {n: z.read(n) for n in z.namelist()}


PARTS = _workbook()
XML = [n for n in PARTS if n.startswith("xl/worksheets/")] + ["xl/workbook.xml"]
HOSTILE = [b'r="1048577"', b'r="XFE1"', b'r="0"', b't="s"', b't="e"', b't="d"', b"<v>1e308</v>",
           b"<v>nan</v>", b"<v>-inf</v>", b"<v></v>", b"<c/>", b"<row/>", b'<row r="2">',
           b"</sheetData>", b"&amp;", b"&#0;", b"<v>99999999999999999999</v>", b'spans="1:99999"']


def _xlsx(rng: random.Random) -> bytes:
    parts = dict(PARTS)
    name = rng.choice(XML)
    b = bytearray(parts[name])
    for _ in range(rng.randint(1, 3)):
        i = rng.randrange(len(b) + 1)
        if rng.random() < 0.6:
            b[i:i] = rng.choice(HOSTILE)
        else:
            b = bytearray(mutate(bytes(b), rng, 1))
    parts[name] = bytes(b)
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_STORED) as z:
        for n, data in parts.items():
            z.writestr(n, data)
    return buf.getvalue()


def fuzz_excel(tmp_path, n: int, salt: str) -> None:
    """``n`` examples of the excel fuzzing (its two test files: different salts)."""
    p = tmp_path / "log.xlsx"
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_STORED) as z:
        for name, data in PARTS.items():
            z.writestr(name, data)
    valid = buf.getvalue()

    def check(rng: random.Random) -> None:
        put(p, _xlsx(rng) if rng.random() < 0.8 else binary_mutate(valid, rng))
        check_trial(safe(read_excel, p, rng.choice([SPEC, SPEC_SKIP])))

    fuzz(check, n, salt)
    assert [q.name for q in tmp_path.iterdir()] == ["log.xlsx"]


def test_excel_reader(tmp_path):
    fuzz_excel(tmp_path, halves()[0], "excel")
