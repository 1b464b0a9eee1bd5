"""Interrupted and concurrent runs: SIGINT and SIGKILL at random moments of ``usvid identify
--out`` and ``usvid demo --quick`` never leave a file under a final name that does not parse;
Ctrl-C exits 130; concurrent writers of one output leave one complete file; two processes
compiling into a fresh numba cache both succeed.

The kill tests fork the test process (modules imported, kernels compiled) and run the CLI's
``main`` in the child, so each run costs the command, not an interpreter start; the signal and
the files on disk are the same as for a separate process. The real ``usvid demo --quick`` runs
once, frozen at N_KILLS or more random moments (each the state a SIGKILL would leave), in
test_demo.py (:func:`run_demo_frozen`: it is also the second run of the same-seed check); real
SIGINTs interrupt a one-manoeuvre demo that writes every kind of file the full demo
writes (logs moved into ``logs/``, format specs, ``run.json``, ``report.html``), and, with
USVID_HEAVY_TESTS=1, the real ``demo --quick`` at N_KILLS + N_REAL_KILLS random moments.
"""

from __future__ import annotations

import contextlib
import json
import multiprocessing
import os
import select
import shutil
import signal
import subprocess
import sys
import time
import warnings
from dataclasses import replace
from pathlib import Path

import numba.np.ufunc.parallel as numba_parallel
import numpy as np
import pytest

import usvid.commands.demo  # noqa: F401  (imported before forking: children start fast)
from usvid.cli import main
from usvid.demo import campaign, pipeline
from usvid.io import load_spec, read_trial
from usvid.io.modelfile import load_model, model_to_dict
from usvid.io.writers import write_csv
from usvid.sim import run_zigzag

REPO = Path(__file__).resolve().parents[1]
EXAMPLES = REPO / "examples"
N_KILLS = 10
N_REAL_KILLS = 4
#: Mean gap [s] between the frozen moments of run_demo_frozen: about two moments per second of
#: the demo, so that a quick demo of 6-12 s wall still gives N_KILLS or more (a 1 s mean gave
#: 11 on a 12 s demo); a moment costs the parent ~0.02 s (only new or changed files are read).
GAP_S = 0.5


@pytest.fixture(scope="module")
def log(tmp_path_factory) -> tuple[Path, Path]:
    d = tmp_path_factory.mktemp("log")
    res, _ = run_zigzag(load_model(EXAMPLES / "lanxin.json"), 10.0, 10.0, t_end=60.0, dt=0.02)
    write_csv(res.to_trial(), d / "log.csv", spec_path=d / "spec.yaml")
    return d / "log.csv", d / "spec.yaml"


def _fork_run(argv: list[str], setup=None, stderr: Path | None = None) -> int:
    """Fork a child that runs ``usvid ARGV`` in process (``main``, as ``sys.exit(main(ARGV))``
    in a process of its own runs it: Python's SIGINT handler, the CLI's SIGTERM handler) after
    ``setup()``, and exits with its code; its stdout and stderr go to /dev/null, or its stderr
    to the file ``stderr``. A fork of this process (modules imported, kernels loaded) rather
    than a new interpreter: ~3 s of CPU less a run."""
    pid = os.fork()
    if pid == 0:  # child
        code = 1
        try:
            try:  # the harness, before the command: an interrupt here is not usvid's
                # numba guards its threading-layer start with a multiprocessing lock created at
                # import; forked siblings share the parent's, and a sibling killed while holding
                # it would block the next ones forever. A separate process has its own: so
                # does this child.
                numba_parallel._backend_init_process_lock = multiprocessing.RLock()
                signal.signal(signal.SIGINT, signal.default_int_handler)
                devnull = os.open(os.devnull, os.O_WRONLY)
                os.dup2(devnull, 1)
                os.dup2(devnull if stderr is None
                        else os.open(stderr, os.O_WRONLY | os.O_CREAT | os.O_TRUNC), 2)
                # Python's streams on those descriptors, not pytest's capture (which writes to
                # a file of the parent's: what the command prints would not reach ``stderr``)
                sys.stdout = open(1, "w", closefd=False)
                sys.stderr = open(2, "w", buffering=1, closefd=False)
                warnings.simplefilter("ignore")
                if setup is not None:
                    setup()
            except KeyboardInterrupt:
                code = 130
                raise
            code = main(argv)
        finally:
            with contextlib.suppress(Exception):  # (os._exit flushes nothing)
                sys.stdout.flush()
                sys.stderr.flush()
            os._exit(code)
    return pid


def _wait(pid: int, timeout: float = 120.0) -> int:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            return os.waitstatus_to_exitcode(status)
        time.sleep(0.01)
    os.kill(pid, signal.SIGKILL)
    os.waitpid(pid, 0)
    raise AssertionError(f"child process {pid} hung")


def _timed(argv: list[str], setup=None) -> float:
    t0 = time.monotonic()
    assert _wait(_fork_run(argv, setup)) == 0
    return time.monotonic() - t0


def _moments(seed: int, span: float) -> list[float]:
    rng = np.random.default_rng(seed)
    return list(rng.uniform(0.0, span, N_KILLS))


# ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGKILL], ids=["SIGINT", "SIGKILL"])
def test_identify_killed_at_random_moments(log, tmp_path, sig) -> None:
    csv, spec = log
    out = tmp_path / "m.json"
    argv = ["identify", str(csv), "--format", str(spec), "--model", "nomoto1", "--method", "oe",
            "--out", str(out)]
    span = _timed(argv) * 1.2  # a full run, then kill moments over it (and a little after)
    out.unlink()
    codes = []
    for k, when in enumerate(_moments(int(sig), span)):
        if k % 2:  # half of the runs overwrite an existing (complete) file
            out.write_text(json.dumps(model_to_dict(load_model(EXAMPLES / "lanxin.json"))))
        pid = _fork_run(argv)
        time.sleep(when)
        os.kill(pid, sig)
        code = _wait(pid)
        codes.append(code)
        if sig == signal.SIGINT:
            assert code in (0, 130), code  # interrupted cleanly, or finished first
        if out.exists():
            load_model(out)  # complete, whatever the moment
        left = sorted(p.name for p in tmp_path.iterdir() if p.name != "m.json")
        if sig == signal.SIGKILL:  # a kill -9 between creating the temporary file and the
            # rename leaves the temporary file (dot-named, never under the final name)
            assert all(n.startswith(".m.json.") and n.endswith(".tmp") for n in left), left
            for n in left:
                (tmp_path / n).unlink()
        else:
            assert left == []  # Ctrl-C cleans its temporary file up
        if out.exists():
            out.unlink()
    assert any(c != 0 for c in codes)  # the signals did interrupt runs


def _check_parses(out: Path, seen: dict) -> int:
    """Every file under a final name in the demo folder ``out`` parses: logs read back with
    their reader (a ROS 2 bag folder as one log), format specs and model files load, ``run.json``
    parses, ``report.html`` ends; names starting with a dot (the temporary files) are skipped.
    Files already checked (same size and time) are not read again. Returns the number of files
    checked now."""
    n = 0
    if not out.exists():
        return n
    for p in sorted(out.rglob("*")):
        rel = p.relative_to(out)
        if any(part.startswith(".") for part in rel.parts):
            continue
        if p.is_dir() and (p / "metadata.yaml").exists():  # a ROS 2 bag: published as one folder
            key = (str(rel), p.stat().st_mtime_ns)
            if key not in seen:
                read_trial(p)
                seen[key] = True
                n += 1
            continue
        if not p.is_file() or (p.parent / "metadata.yaml").exists():
            continue
        st = p.stat()
        key = (str(rel), st.st_size, st.st_mtime_ns)
        if key in seen:
            continue
        if p.suffix == ".json":
            d = json.loads(p.read_text())
            if rel.parts[0] == "models" and "usvid_model" in d:  # (servo.json: parameters)
                load_model(p)
        elif p.suffix == ".html":
            assert p.read_text().rstrip().endswith("</html>"), p
        elif p.suffix == ".yaml":
            load_spec(p)
        elif p.suffix == ".csv":
            spec = p.parent / "lanxin_logger_csv.yaml"
            read_trial(p, spec if spec.exists() else None)
        else:
            read_trial(p)
        seen[key] = True
        n += 1
    return n


def _stopped(pid: int) -> bool:
    """SIGSTOP ``pid`` and wait until it is stopped; False when it exited first."""
    os.kill(pid, signal.SIGSTOP)
    _, status = os.waitpid(pid, os.WUNTRACED)
    if os.WIFSTOPPED(status):
        return True
    assert os.waitstatus_to_exitcode(status) == 0
    return False


def run_demo_frozen(out: Path, seed: int) -> tuple[float, int]:
    """The real ``usvid demo --quick --seed SEED --out OUT`` in a forked child, frozen (SIGSTOP)
    at seeded random moments (gaps drawn from an exponential law, mean GAP_S) until it ends: at
    each, every file under a final name must parse. A SIGKILL does nothing more to the files
    than stopping the process at that moment does (no handler runs; what was written stays), so
    each frozen state is the state a kill -9 at that moment would leave. Returns the run time
    [s] without the frozen spans and the number of frozen moments (at least N_KILLS).
    test_demo.py runs it as the second run of its same-seed check (one real demo less)."""
    rng = np.random.default_rng(13)
    seen: dict = {}
    pid = _fork_run(["demo", "--quick", "--seed", str(seed), "--out", str(out)])
    t0, frozen, moments = time.monotonic(), 0.0, 0
    while True:
        time.sleep(rng.exponential(GAP_S))
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            assert os.waitstatus_to_exitcode(status) == 0
            break
        f0 = time.monotonic()
        if not _stopped(pid):
            break
        _check_parses(out, seen)
        moments += 1
        os.kill(pid, signal.SIGCONT)
        frozen += time.monotonic() - f0
    duration = time.monotonic() - t0 - frozen
    _check_parses(out, seen)
    assert (out / "report.html").exists() and (out / "run.json").exists()
    assert moments >= N_KILLS, f"the demo ended after {moments} frozen moments"
    return duration, moments


@pytest.fixture(scope="module")
def demo_run(tmp_path_factory) -> float:
    """The run time [s] of the real ``usvid demo --quick`` (the heavy test's time span)."""
    return _timed(["demo", "--quick", "--out", str(tmp_path_factory.mktemp("demo") / "run")])


@pytest.mark.skipif(not os.environ.get("USVID_HEAVY_TESTS"),
                    reason="14 real demo runs (about 100 s of CPU on an idle 2-core machine, 13 "
                           "min wall under load); set USVID_HEAVY_TESTS=1")
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGKILL], ids=["SIGINT", "SIGKILL"])
def test_demo_signalled_at_random_moments(demo_run, tmp_path, sig) -> None:
    """Real signals at seeded random moments over the measured run time of ``demo --quick``,
    two runs at a time: SIGINT exits 130 (or 0 when the run had finished) and leaves no
    temporary file; after either signal every file under a final name parses."""
    n = N_KILLS if sig == signal.SIGINT else N_REAL_KILLS
    moments = list(np.random.default_rng(100 + int(sig)).uniform(0.0, demo_run, n))
    codes = []
    for k in range(0, n, 2):
        runs = []
        for j, when in enumerate(moments[k:k + 2]):
            out = tmp_path / f"run{k + j}"
            runs.append((out, when, _fork_run(["demo", "--quick", "--out", str(out)])))
        t0 = time.monotonic()
        for _, when, pid in sorted(runs, key=lambda r: r[1]):
            time.sleep(max(0.0, when - (time.monotonic() - t0)))
            os.kill(pid, sig)
        for out, _, pid in runs:
            code = _wait(pid, 600.0)
            codes.append(code)
            if sig == signal.SIGINT:
                assert code in (0, 130), code
                left = [p for p in out.rglob(".*") if p.name != ".usvid-run"] if out.exists() \
                    else []
                assert left == [], left
            _check_parses(out, {})
            shutil.rmtree(out, ignore_errors=True)
    assert any(c != 0 for c in codes)  # the signals did interrupt runs


#: The demo's steps the mini demo skips: the analysis steps and the papers' headline numbers
#: (pure computation writing no file, ~2/3 of a mini demo's CPU when it ran: the Ma et al.
#: prediction interval's searches). A SIGINT during computation is still met, in the campaign
#: step's simulation; every kind of file the demo writes is still written.
MINI_SKIPPED = ("step_read", "step_audit", "step_identify", "step_validate",
                "step_course_keeping", "step_turning_diameter", "step_papers")


def _mini_demo():
    """Child setup: a one-manoeuvre campaign of 15 s; the analysis steps skipped."""
    full = campaign.programme

    def one(quick: bool = False):
        return [replace(m, duration_s=15.0) for m in full(quick) if m.name == "zigzag_10_10"]

    campaign.programme = one

    def skip(self):
        raise pipeline.Skipped("skipped in the interrupt test")

    for name in MINI_SKIPPED:
        setattr(pipeline.DemoPipeline, name, skip)


def _check_demo_dir(out: Path, ref: Path) -> None:
    """Every file under a final name is complete: logs and specs byte-identical to those of the
    complete reference run (same seed, same bytes), ``run.json`` parses, ``report.html`` ends;
    temporary names start with a dot."""
    if not out.exists():
        return
    for p in out.rglob("*"):
        rel = p.relative_to(out)
        if any(part.startswith(".") for part in rel.parts) or p.is_dir():
            continue
        if p.suffix == ".json":
            json.loads(p.read_text())
        elif p.suffix == ".html":
            assert p.read_text().rstrip().endswith("</html>"), p
        else:
            assert p.read_bytes() == (ref / rel).read_bytes(), p


@pytest.fixture(scope="module")
def demo_ref(tmp_path_factory) -> tuple[Path, float]:
    """A complete mini demo run and the duration [s] of one in a forked child.

    The reference runs in this process first (the mini demo's setup undone after it): the
    libraries the campaign's writers load on first use (ROS bags, NMEA 2000, ...; ~1 s of CPU)
    are then loaded before forking, as the demo's commands are, and the kill moments fall on
    the run's own work rather than mostly on those imports."""
    ref = tmp_path_factory.mktemp("demo") / "ref"
    saved = campaign.programme, {n: getattr(pipeline.DemoPipeline, n) for n in MINI_SKIPPED}
    try:
        _mini_demo()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            assert main(["demo", "--quick", "--out", str(ref)]) == 0
    finally:
        campaign.programme = saved[0]
        for n, f in saved[1].items():
            setattr(pipeline.DemoPipeline, n, f)
    return ref, _timed(["demo", "--quick", "--out", str(ref.parent / "timed")], _mini_demo)


# SIGKILL: the frozen states of the real demo (test_demo.py::test_demo_frozen_at_random_moments)
# stand for kill -9 at any moment; real kills of the real demo run with USVID_HEAVY_TESTS=1
@pytest.mark.parametrize("sig", [signal.SIGINT], ids=["SIGINT"])
def test_mini_demo_killed_at_random_moments(demo_ref, tmp_path, sig) -> None:
    ref, duration = demo_ref
    moments = _moments(100 + int(sig), 1.2 * duration)
    # the moments scale with one timed run; on a loaded machine (a cold suite compiling on the
    # other cores) that run took over 5 times as long as the runs killed after it, and all ten
    # kills landed after the end (measured once): then kill again, each time at half the
    # earliest moment, until one lands inside a run (at most 6 times, down to 1/64 of it)
    earliest = min(moments)
    moments += [earliest / 2**i for i in range(1, 7)]
    codes: list[int] = []
    for k, when in enumerate(moments):
        if k >= N_KILLS and any(c != 0 for c in codes):
            break
        run = tmp_path / f"run{k}"
        if k % 2:  # half of the runs regenerate a complete earlier run
            shutil.copytree(ref, run)
        pid = _fork_run(["demo", "--quick", "--out", str(run)], _mini_demo)
        time.sleep(when)
        os.kill(pid, sig)
        code = _wait(pid)
        codes.append(code)
        if sig == signal.SIGINT:
            assert code in (0, 130), code
        _check_demo_dir(run, ref)
    assert any(c != 0 for c in codes), (duration, moments, codes)


def test_concurrent_identify_to_one_output(log, tmp_path) -> None:
    """Three processes write the same model file at once: one complete file remains, and no
    temporary file."""
    csv, spec = log
    out = tmp_path / "m.json"
    argv = ["identify", str(csv), "--format", str(spec), "--model", "nomoto1", "--out",
            str(out)]
    pids = [_fork_run(argv) for _ in range(3)]
    assert [_wait(p) for p in pids] == [0, 0, 0]
    load_model(out)
    assert [p.name for p in tmp_path.iterdir()] == ["m.json"]


def _fork_cli(argv: list[str], setup, err: Path) -> tuple[int, int]:
    """:func:`_fork_run` of ``usvid ARGV`` after ``setup(ready)``, ``ready()`` writing a line to
    the pipe whose read end is returned with the pid; its stderr goes to the file ``err``."""
    r, w = os.pipe()

    def child_setup() -> None:
        os.close(r)
        setup(lambda: os.write(w, b"ready\n"))

    pid = _fork_run(argv, child_setup, stderr=err)
    os.close(w)
    return pid, r


def _reap(pid: int) -> None:
    """Kill the child ``pid`` if it still runs, and reap it (a test's cleanup)."""
    with contextlib.suppress(ChildProcessError, ProcessLookupError):
        if os.waitpid(pid, os.WNOHANG)[0] == 0:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)


def _ready(r: int, timeout: float = 120.0) -> bytes:
    """The first line the child writes to the pipe ``r`` (b"" when it ended without one)."""
    buf = b""
    deadline = time.monotonic() + timeout
    while not buf.endswith(b"\n") and time.monotonic() < deadline:
        if select.select([r], [], [], 0.1)[0]:
            chunk = os.read(r, 64)
            if not chunk:
                break
            buf += chunk
    return buf.strip()


def test_ctrl_c_exits_130(log, tmp_path) -> None:
    """A real Ctrl-C (SIGINT to the ``usvid`` process, a child of this one) in the middle of a
    command: exit code 130, one line, no traceback."""
    csv, spec = log
    out = tmp_path / "out"
    out.mkdir()
    err = tmp_path / "stderr.txt"

    def setup(ready) -> None:
        import usvid.identify.estimator as e

        def slow(self, *a, **k):
            ready()
            time.sleep(60)

        e.ModelEstimator.fit = slow

    pid, r = _fork_cli(["identify", str(csv), "--format", str(spec), "--model", "nomoto1",
                        "--out", str(out / "m.json")], setup, err)
    try:
        assert _ready(r) == b"ready", err.read_text()
        os.kill(pid, signal.SIGINT)
        code = _wait(pid, 60.0)
    finally:
        os.close(r)
        _reap(pid)
    assert code == 130
    assert err.read_text().strip() == "usvid: interrupted"
    assert not (out / "m.json").exists()


def _child(code: str, **kw) -> subprocess.Popen:
    """``python -c CODE`` in a session of its own (a terminal's Ctrl-C reaches its whole
    process group: os.killpg), stdout and stderr piped."""
    return subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, cwd=REPO, start_new_session=True, **kw)


def _finish(proc: subprocess.Popen, timeout: float = 120) -> tuple[int, str]:
    try:
        _, err = proc.communicate(timeout=timeout)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    return proc.returncode, err.decode()


def test_sigterm_exits_143_like_ctrl_c(log, tmp_path) -> None:
    """SIGTERM in the middle of a command is handled as Ctrl-C: exit 143, one line, and a
    SIGTERM between writing the output's temporary file and renaming it removes the temporary
    file (the fsync is held back to reach that moment)."""
    csv, spec = log
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    out = out_dir / "m.json"
    err = tmp_path / "stderr.txt"
    for stage in ("fit", "fsync"):
        def setup(ready, stage=stage) -> None:
            import usvid.files as f
            import usvid.identify.estimator as e

            orig_fit = e.ModelEstimator.fit

            def fit(self, *a, **k):
                if stage == "fit":
                    ready()
                    time.sleep(60)
                return orig_fit(self, *a, **k)

            def fsync(fd):
                ready()
                time.sleep(60)

            e.ModelEstimator.fit = fit
            if stage == "fsync":
                f.os.fsync = fsync  # (the child's os module: this process's is untouched)

        pid, r = _fork_cli(["identify", str(csv), "--format", str(spec), "--model", "nomoto1",
                            "--out", str(out)], setup, err)
        try:
            assert _ready(r) == b"ready", (stage, err.read_text())
            names = [p.name for p in out_dir.iterdir()]
            if stage == "fit":
                assert names == []
            else:  # the temporary file is written, not yet renamed
                assert len(names) == 1 and names[0].startswith(".m.json.") \
                    and names[0].endswith(".tmp"), names
            os.kill(pid, signal.SIGTERM)
            rc = _wait(pid, 120.0)
        finally:
            os.close(r)
            _reap(pid)
        text = err.read_text()
        assert rc == 143 and text.strip() == "usvid: terminated", (stage, rc, text[-2000:])
        assert list(out_dir.iterdir()) == [], stage  # no model file, no temporary file


def test_ctrl_c_while_the_cli_starts_is_quiet() -> None:
    """Ctrl-C while ``usvid.cli`` is still being imported (here: when it imports typer): exit
    130 with one line, not a KeyboardInterrupt traceback nor death by the signal (-2)."""
    code = ("import builtins, os, signal\n"
            "real = builtins.__import__\n"
            "def imp(name, *a, **k):\n"
            "    if name == 'typer':\n"
            "        os.kill(os.getpid(), signal.SIGINT)\n"
            "    return real(name, *a, **k)\n"
            "builtins.__import__ = imp\n"
            "from usvid.cli import main\n"
            "print('not reached')\n")
    rc, err = _finish(_child(code))
    assert rc == 130 and err.strip() == "usvid: interrupted", (rc, err[-2000:])


_SCALE = """
import sys
import usvid.scale.batch as b, usvid.scale.cluster as c, usvid.scale.montecarlo as m
from usvid.cli import main
real = c.map_ordered
def announce(*a, **k):
    print('tasks', flush=True)
    return real(*a, **k)
b.map_ordered = m.map_ordered = announce
sys.exit(main({argv!r}))
"""


def _running(psutil, pid: int) -> bool:
    try:
        return psutil.Process(pid).status() != psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return False


def test_ctrl_c_during_dask_montecarlo_and_batch_is_quiet(tmp_path) -> None:
    """A terminal's Ctrl-C (SIGINT to the whole process group: the command and its Dask
    worker processes) while montecarlo (on a local cluster: --workers above the cores) and
    batch run their tasks: exit 130, exactly one line "usvid: interrupted" (no traceback, no
    Dask log line, no worker's traceback), no temporary file, no process left."""
    psutil = pytest.importorskip("psutil")
    from test_scale import SPEC, _write_log

    model = tmp_path / "m.json"
    model.write_text(json.dumps(model_to_dict(load_model(EXAMPLES / "lanxin.json"))))
    (tmp_path / "spec.yaml").write_text(SPEC)
    for i in range(4):
        _write_log(tmp_path / f"run{i}.csv", 0.3, 10 + i, seed=i)
    groups = [{"name": f"g{i}", "logs": ["*.csv"], "spec": "spec.yaml",
               "kinds": ["nomoto1", "norrbin"], "method": "oe"} for i in range(8)]
    (tmp_path / "c.yaml").write_text(json.dumps({"groups": groups}))
    cores = len(os.sched_getaffinity(0))
    runs = [["montecarlo", str(model), "--manoeuvre", "zigzag", "--runs", "2000000",
             "--chunk", "4000", "--vary", "K=normal:0.707,0.01", "--workers", str(cores + 1),
             "--out", str(tmp_path / "mc.parquet")],
            ["batch", str(tmp_path / "c.yaml"), "--out", str(tmp_path / "out")]]
    for argv in runs:
        proc = _child(_SCALE.format(argv=argv))
        assert proc.stdout.readline().strip() == b"tasks", _finish(proc)
        time.sleep(1.0)  # the tasks run on the workers
        family = [proc.pid, *(p.pid for p in psutil.Process(proc.pid).children(recursive=True))]
        os.killpg(proc.pid, signal.SIGINT)
        rc, err = _finish(proc)
        assert rc == 130 and err.strip() == "usvid: interrupted", (argv[0], rc, err[-3000:])
        time.sleep(0.5)
        assert [p for p in family if _running(psutil, p)] == [], argv[0]
        assert [p.name for p in tmp_path.rglob("*.tmp")] == []
        assert not (tmp_path / "mc.parquet").exists()


NUMBA_MODULE = """
import numba, sys

@numba.njit(cache=True)
def f(x):
    s = 0.0
    for i in range(x.shape[0]):
        s += x[i] * x[i]
    return s

import numpy as np
print(f(np.arange(10.0)))
"""


def test_two_processes_compile_into_a_fresh_numba_cache_small(tmp_path) -> None:
    """The mechanism of the integration core's disk cache (``numba.njit(cache=True)``), on a
    small function: two processes compiling into an empty cache at once both succeed, and the
    index they leave is used by a third."""
    (tmp_path / "mod.py").write_text(NUMBA_MODULE)
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    argv = [sys.executable, str(tmp_path / "mod.py")]
    procs = [subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
             for _ in range(2)]
    outs = [p.communicate(timeout=300) for p in procs]
    assert [p.returncode for p in procs] == [0, 0], [o[1].decode()[-2000:] for o in outs]
    assert [o[0].strip() for o in outs] == [b"285.0", b"285.0"]
    assert any((tmp_path / "cache").rglob("*.nbi"))
    third = subprocess.run(argv, capture_output=True, env=env, timeout=300)
    assert third.returncode == 0 and third.stdout.strip() == b"285.0"


@pytest.mark.skipif(not os.environ.get("USVID_HEAVY_TESTS"),
                    reason="compiles the whole integration core twice (about a minute on 2 "
                           "cores); set USVID_HEAVY_TESTS=1")
def test_two_processes_compile_into_a_fresh_numba_cache(tmp_path) -> None:
    """Two processes compile the integration core for the same kind into an empty numba cache
    at the same time; both succeed with the same result."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache"), "PYTHONWARNINGS": "ignore"}
    argv = [sys.executable, "-m", "usvid.cli", "simulate", "zigzag",
            str(EXAMPLES / "lanxin.json"), "--t-end", "30", "--json"]
    procs = [subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env,
                              cwd=REPO) for _ in range(2)]
    outs = [p.communicate(timeout=300) for p in procs]
    assert [p.returncode for p in procs] == [0, 0], [o[1].decode()[-2000:] for o in outs]
    a, b = (json.loads(o[0]) for o in outs)
    assert a == b
    assert any((tmp_path / "cache").rglob("*.nbi"))  # the index files were written
