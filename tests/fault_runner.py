"""Run fault-matrix cases in this process, each under a time limit, and report them as JSON.

``python fault_runner.py CASES.json``: CASES.json is a list of ``[id, argv]``; every case runs
``usvid.cli.main(argv)`` in this process (imports paid once) under ``signal.alarm`` of
LIMIT_S seconds. Printed on stdout, one JSON object per line: ``{"id", "code", "err",
"seconds"}`` per case (``code`` "timeout" when the alarm fired), then ``{"maxrss_kb"}`` of this
process (its peak resident memory over all cases: every case stays below it) and of its
children. Used by test_faults.py for the cases that would hang or exhaust memory without their
guards (FIFOs, /dev/zero, a one-line 200 MB table, resource bombs of the scale-out commands).
"""

from __future__ import annotations

import contextlib
import io
import json
import resource
import signal
import sys
import time
import warnings

#: Time limit of one case [s].
LIMIT_S = 30


class CaseTimeout(BaseException):
    """The case ran out of time (not an Exception: the CLI does not catch it)."""


def _alarm(signum: int, frame: object) -> None:
    raise CaseTimeout()


def main() -> None:
    from usvid.cli import main as cli

    cases = json.loads(open(sys.argv[1], encoding="utf-8").read())
    signal.signal(signal.SIGALRM, _alarm)
    for cid, argv in cases:
        err = io.StringIO()
        t0 = time.perf_counter()
        signal.alarm(LIMIT_S)
        try:
            with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()), \
                    contextlib.redirect_stderr(err):
                warnings.simplefilter("ignore")
                code: int | str = cli(argv)
        except CaseTimeout:
            code = "timeout"
        finally:
            signal.alarm(0)
        print(json.dumps({"id": cid, "code": code, "err": err.getvalue()[-3000:],
                          "seconds": round(time.perf_counter() - t0, 3)}), flush=True)
    print(json.dumps({
        "maxrss_kb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss,
        "children_maxrss_kb": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss}))


if __name__ == "__main__":
    main()
