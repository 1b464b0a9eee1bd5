"""The report's "Papers" section: the papers' headline numbers the demo recomputed on the shipped
example models (``run["papers"]``, written by :mod:`usvid.demo.papers`; docs/papers.md holds
every row with its arithmetic)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from usvid.report.html import _table, _unavailable, esc

#: Section id and title (the report's navigation).
SECTION = ("papers", "Papers")


def papers_section(run: Mapping[str, Any]) -> str:
    """HTML of the section: one row per headline number (paper, quantity, the paper's value,
    usvid's, the command that prints it, status)."""
    out = ['<h2 id="papers">The papers\' headline numbers</h2>']
    entry = run.get("papers")
    if not entry or not entry.get("rows"):
        return "".join(out) + _unavailable(run, "papers", "The papers' headline numbers")
    if entry.get("description"):
        out.append(f"<p>{esc(entry['description'])}</p>")
    rows = [[esc(r.get("paper", "")), esc(r.get("quantity", "")), esc(r.get("paper_value", "")),
             esc(r.get("usvid_value", "")), f"<code>{esc(r.get('command', ''))}</code>",
             esc(r.get("status", ""))] for r in entry["rows"]]
    out.append(_table(["paper", "quantity", "paper", "usvid", "command", "status"], rows,
                      left=6))
    return "".join(out)
