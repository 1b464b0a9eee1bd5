"""CLI: ``usvid example NAME --out DIR [--json]`` - copy an example model file shipped with
usvid (package data ``usvid/data/examples``) into ``DIR``.

Examples: ``lanxin`` (Nomoto, Mu et al. 2018), ``lanxin_norrbin``, ``lanxin_threedof`` (Mu et
al. 2018, eq. 37), ``pod_usv`` (podded USV, Mu et al. 2016, K and T as its text prints them) and
``pod_usv_eq25`` (the same with K and T of its eq. 25 as printed) and ``catamaran`` (twin
thrusters, the catamaran paper). JSON: ``example``, ``file``.
An existing file is not overwritten (exit 2 naming it).
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path
from typing import Annotated

import typer

EXAMPLES = ("lanxin", "lanxin_norrbin", "lanxin_threedof", "pod_usv", "pod_usv_eq25",
            "catamaran")

NameArg = Annotated[str, typer.Argument(help="Example: " + " | ".join(EXAMPLES) + ".",
                                        show_default=False)]
OutOpt = Annotated[Path, typer.Option("--out", "-o", help="Folder to copy the example into.")]
JsonOpt = Annotated[bool, typer.Option("--json", help="Print one JSON object on stdout.")]


def copy_example(name: str, out: Path) -> Path:
    """Copy example ``name`` to ``out/NAME.json`` (atomically; never over an existing file)."""
    from usvid.errors import UsvidError
    from usvid.files import write_atomic

    if name not in EXAMPLES:
        raise UsvidError(f"example {name!r} is not shipped (choose one of: "
                         f"{', '.join(EXAMPLES)})")
    target = Path(out) / f"{name}.json"
    if target.exists():
        raise UsvidError(f"--out {out}: {target.name} exists already; not overwritten")
    text = resources.files("usvid").joinpath("data", "examples", f"{name}.json").read_text(
        encoding="utf-8")
    Path(out).mkdir(parents=True, exist_ok=True)
    return write_atomic(target, text)


def register(app: typer.Typer) -> None:
    """Register ``usvid example``."""

    @app.command("example")
    def example_cmd(name: NameArg, out: OutOpt = Path("."), json_out: JsonOpt = False) -> None:
        """Copy an example model file shipped with usvid into a folder."""
        path = copy_example(name, out)
        if json_out:
            from usvid.commands._common import emit_json

            emit_json({"example": name, "file": str(path)})
        else:
            print(f"example {name} -> {path}")
