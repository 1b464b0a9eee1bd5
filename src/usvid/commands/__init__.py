"""CLI commands, one module each; every module defines ``register(app)``.

The CLI contract (options and ``--json`` keys) is documented in the README.
"""

#: Modules registered on the CLI, in help order.
COMMAND_MODULES = [
    "simulate",
    "autopilot",
    "audit",
    "metrics",
    "identify",
    "validate",
    "fit_turning_diameter",
    "demo",
    "report",
    "example",
    "montecarlo",
    "batch",
]
