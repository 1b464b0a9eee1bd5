"""The package's layers: data flows one way, no import cycles, imports at module top.

The layers contract (``[tool.importlinter]`` in pyproject.toml) is checked with import-linter:
cli > commands > demo > report > identify | control (independent) > sim > prep > io > models >
trial/files > errors. A new import against the flow (or a cycle, which always is one) fails
this test.
"""

from __future__ import annotations

import ast
from pathlib import Path

from importlinter.cli import lint_imports

SRC = Path(__file__).resolve().parents[1] / "src" / "usvid"


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
        local += _local_usvid_imports(path)
    assert local == [], "usvid imports inside functions: " + ", ".join(sorted(set(local)))
