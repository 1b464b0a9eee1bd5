"""The report's "Papers" section: the papers' headline numbers the demo recomputed on the shipped
example models (``run["papers"]``, written by :mod:`usvid.demo.papers`; docs/papers.md holds
every row with its arithmetic).

The report's HTML helpers are passed in by :func:`usvid.report.html.build_html` (this module is
imported by it, so it cannot import them back)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

#: Section id and title (the report's navigation).
SECTION = ("papers", "Papers")


def papers_section(run: Mapping[str, Any], *, esc: Callable[[Any], str],
                   table: Callable[..., str], unavailable: Callable[..., str]) -> str:
    """HTML of the section: one row per headline number (paper, quantity, the paper's value,
    usvid's, the command that prints it, status). ``esc``, ``table`` and ``unavailable`` are
    the report's escaping, table and "not available" helpers."""
    out = ['<h2 id="papers">The papers\' headline numbers</h2>']
    entry = run.get("papers")
    if not entry or not entry.get("rows"):
        return "".join(out) + unavailable(run, "papers", "The papers' headline numbers")
    if entry.get("description"):
        out.append(f"<p>{esc(entry['description'])}</p>")
    rows = [[esc(r.get("paper", "")), esc(r.get("quantity", "")), esc(r.get("paper_value", "")),
             esc(r.get("usvid_value", "")), f"<code>{esc(r.get('command', ''))}</code>",
             esc(r.get("status", ""))] for r in entry["rows"]]
    out.append(table(["paper", "quantity", "paper", "usvid", "command", "status"], rows,
                     left=6))
    return "".join(out)
