"""CLI commands, one module each; every module defines ``register(app)``.

The CLI contract (options and ``--json`` keys) is documented in the README.
"""

#: Each command of the CLI, in help order: its module and its summary, the first sentence of
#: its help (``usvid --help`` lists the commands from here without importing their modules;
#: tests/test_cli_lazy.py checks that each summary is its command's own).
COMMANDS = {
    "autopilot": ("autopilot", "Heading-autopilot gains from a model: pole placement or "
                  "ITAE-optimal, with margins."),
    "audit": ("audit", "Check each channel of a log against the physics and report what is "
              "wrong."),
    "metrics": ("metrics", "Find zig-zags and turning circles in a log and print their "
                "measured metrics."),
    "identify": ("identify", "Identify a manoeuvring model from trial logs and write the model "
                 "file."),
    "validate": ("validate", "Validate a model file on logs: predicted vs measured manoeuvres, "
                 "free-run replay."),
    "fit-turning-diameter": ("fit_turning_diameter", "Fit Ma et al.'s relative turning "
                             "diameter D/L(Fr, delta) by CGA and least squares."),
    "demo": ("demo", "Virtual Lanxin sea trials -> identified, validated models -> "
             "report.html."),
    "report": ("report", "Regenerate the self-contained HTML report (report.html) from "
               "RUN_DIR/run.json."),
    "example": ("example", "Copy an example model file shipped with usvid into a folder."),
    "montecarlo": ("montecarlo", "Monte-Carlo simulation of a manoeuvre over parameter "
                   "uncertainty (Dask)."),
    "batch": ("batch", "Identify and validate groups of logs of a campaign, one Dask task per "
              "group."),
    "simulate": ("simulate", "Simulate a standard manoeuvre on a model file and print its "
                 "metrics."),
}

#: The command modules (each registers its command on the CLI app).
COMMAND_MODULES = [module for module, _ in COMMANDS.values()]
