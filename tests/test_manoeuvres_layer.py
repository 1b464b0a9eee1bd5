"""usvid.manoeuvres sits above usvid.prep and below usvid.sim: it imports neither the simulator,
identification, the report, the CLI nor the readers, and only at module top."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import usvid.manoeuvres

PACKAGE = Path(usvid.manoeuvres.__file__).parent
ABOVE = ("usvid.sim", "usvid.identify", "usvid.report", "usvid.commands", "usvid.io",
         "usvid.cli", "usvid.demo")


def test_importing_the_package_loads_nothing_above_it():
    code = ("import sys, usvid.manoeuvres; "
            f"print(sorted(m for m in sys.modules if m.startswith({ABOVE!r})))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == "[]"


def test_usvid_imports_only_at_module_top():
    for path in sorted(PACKAGE.glob("*.py")):
        tree = ast.parse(path.read_text())
        top = set(map(id, tree.body))
        for node in tree.body:  # the names the package loads on first use (PEP 562), for
            if isinstance(node, ast.If) and ast.unparse(node.test) == "TYPE_CHECKING":
                top |= set(map(id, node.body))  # the type checker and the layers contract
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                names = [node.module or ""]
            elif isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            else:
                continue
            for name in (n for n in names if n.startswith("usvid")):
                assert id(node) in top, f"{path.name}:{node.lineno}: function-local import"
                assert not name.startswith(ABOVE), f"{path.name}: imports {name}"
