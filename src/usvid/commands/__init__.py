"""CLI commands, one module each; every module defines ``register(app)``.

The CLI contract (options and ``--json`` keys) is in ``../shared/ARCHITECTURE.md``.
"""

#: Modules registered on the CLI, in help order.
COMMAND_MODULES = [
    "simulate",
    "audit",
    "metrics",
    "identify",
    "fit_turning_diameter",
    "demo",
    "report",
    "montecarlo",
    "batch",
]
