"""The package's layers: data flows one way, no import cycles, imports at module top.

The layers contract (``[tool.importlinter]`` in pyproject.toml) is checked with import-linter:
cli > commands > scale > demo > report > identify | control (independent) > sim > manoeuvres >
prep > io > models > trial/files > errors; and the commands are independent of each other (a
command never imports another; shared code is a layer down or in ``usvid.commands._common``).
A new import against the flow (or a cycle, which always is one) fails this test.
"""

from __future__ import annotations

import ast
from pathlib import Path

from importlinter.cli import lint_imports

SRC = Path(__file__).resolve().parents[1] / "src" / "usvid"


def test_every_command_is_in_the_independence_contract():
    import tomllib

    from usvid.commands import COMMAND_MODULES

    cfg = tomllib.loads((SRC.parents[1] / "pyproject.toml").read_text(encoding="utf-8"))
    contracts = cfg["tool"]["importlinter"]["contracts"]
    independent = next(c for c in contracts if c["type"] == "independence")["modules"]
    assert sorted(independent) == sorted(f"usvid.commands.{m}" for m in COMMAND_MODULES)


def test_layers_contract_is_kept():
    assert lint_imports(config_filename=str(SRC.parents[1] / "pyproject.toml"),
                        no_cache=True, no_logo=True) == 0


def _local_usvid_imports(path: Path) -> list[str]:
    """``file:line`` of every import of a usvid module inside a function or class body."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    out = []
    for node in ast.walk(tree):
        if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            continue
        for sub in ast.walk(node):
            if isinstance(sub, ast.ImportFrom) and (sub.module or "").startswith("usvid"):
                out.append(f"{path.relative_to(SRC.parent)}:{sub.lineno}")
            elif isinstance(sub, ast.Import) and any(a.name.startswith("usvid")
                                                      for a in sub.names):
                out.append(f"{path.relative_to(SRC.parent)}:{sub.lineno}")
    return out


def test_imports_at_module_top_outside_the_cli():
    # the CLI imports its commands' libraries lazily (``usvid --help`` stays fast); the library
    # imports at module top, so that its dependencies are visible to the layers contract
    local = []
    for path in sorted(SRC.rglob("*.py")):
        if path.name == "cli.py" or "commands" in path.parts:
            continue
        if path == SRC / "__init__.py":  # the package root's lazy Trial/Vessel/Finding (PEP 562)
            continue
        local += _local_usvid_imports(path)
    assert local == [], "usvid imports inside functions: " + ", ".join(sorted(set(local)))
