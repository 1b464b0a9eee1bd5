"""Dask clients for the scale-out commands: a local cluster or an existing scheduler, and an
ordered map of tasks with a progress bar on stderr.

A local cluster has one single-threaded worker process per core (the simulation kernel runs
nogil numba code: processes avoid sharing one interpreter; each task sets numba to one thread).
It listens only on 127.0.0.1, on ports the system picks, for its own workers: no dashboard and
no HTTP server (Dask's scheduler would otherwise serve one on port 8787), and its workers print
nothing (their standard error is /dev/null: a Ctrl-C reaches them too, and the command, which
stops them, reports it once). Dask's own log lines are silenced
while a client is open: a task that fails is one error of the command (:func:`map_ordered`).

- :func:`check_scheduler_address` ``(address)``: ``tcp://HOST:PORT`` or ``HOST:PORT``, checked
  before connecting (other Dask protocols need a set-up usvid does not make).
- :func:`check_workers` ``(workers)``: the bound of ``--workers`` on this machine
  (:func:`max_workers`).
"""

from __future__ import annotations

import gc
import ipaddress
import logging
import os
import re
import signal
import sys
import threading
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

from usvid.errors import UsvidError
from usvid.scale import _quiet

__all__ = ["available_memory", "check_scheduler_address", "check_workers", "connect", "cores",
           "map_ordered", "max_workers"]

#: Most local workers per core (more only share the cores and add memory).
WORKERS_PER_CORE = 4
#: Memory a local worker process needs [bytes] (interpreter, numpy/pandas/numba and the loaded
#: kernel: 150-200 MB measured resident), so the workers of one machine fit in its memory.
WORKER_BYTES = 250 * 2**20
#: How long to wait for a scheduler [s].
CONNECT_TIMEOUT_S = 10

_HOST = re.compile(r"^(?=.{1,253}$)[A-Za-z0-9](?:[A-Za-z0-9-]{0,61}[A-Za-z0-9])?"
                   r"(?:\.[A-Za-z0-9](?:[A-Za-z0-9-]{0,61}[A-Za-z0-9])?)*$")


def check_scheduler_address(address: str) -> str:
    """``address`` as ``tcp://HOST:PORT`` when it is one (``HOST:PORT`` gets ``tcp://``), else
    a one-line :class:`UsvidError` naming ``--scheduler``. HOST is a name, an IPv4 address or
    a bracketed IPv6 address; PORT 1..65535. ``inproc://`` (this process only), ``tls://``
    (needs certificates), ``ucx://``, ``ws://`` and anything else are refused before any
    connection is tried."""
    text = str(address).strip()
    why = None
    scheme, sep, rest = text.partition("://")
    if not sep:
        scheme, rest = "tcp", text
    if scheme != "tcp":
        why = (f"protocol {scheme}:// is not supported (usvid connects to a Dask scheduler "
               "over tcp://)")
    else:
        m = re.fullmatch(r"(\[[^\]]*\]|[^:/\[\]]*):(\d{1,5})", rest)
        if m is None:
            why = "expected tcp://HOST:PORT (e.g. tcp://head:8786)"
        else:
            host, port = m.group(1), int(m.group(2))
            ok_host = _HOST.match(host) is not None
            if host.startswith("["):
                try:
                    ok_host = ipaddress.ip_address(host[1:-1]).version == 6
                except ValueError:
                    ok_host = False
            if not ok_host:
                why = f"{host!r} is not a host name or IP address"
            elif not 1 <= port <= 65535:
                why = f"port {port} is not in 1..65535"
    if why is not None:
        shown = text if len(text) <= 80 else text[:80] + "..."
        raise UsvidError(f"--scheduler {shown!r}: {why}")
    return f"tcp://{rest}"


def cores() -> int:
    """The cores this process may use (its CPU affinity, else the machine's)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def available_memory() -> int | None:
    """Memory available to new processes [bytes] (None when the system does not say)."""
    try:
        import psutil

        return int(psutil.virtual_memory().available)
    except Exception:  # noqa: BLE001 - best effort: no bound from memory then
        return None


def max_workers() -> tuple[int, str]:
    """The most local workers on this machine and the reason in words:
    :data:`WORKERS_PER_CORE` per core, and no more than the available memory holds at
    :data:`WORKER_BYTES` each."""
    n = WORKERS_PER_CORE * cores()
    why = f"{WORKERS_PER_CORE} per core, {cores()} core(s)"
    mem = available_memory()
    if mem is not None and mem // WORKER_BYTES < n:
        n = max(1, mem // WORKER_BYTES)
        why = (f"{mem / 2**30:.1f} GB of memory available, about "
               f"{WORKER_BYTES / 2**20:.0f} MB per worker process")
    return n, why


def check_workers(workers: int | None) -> None:
    """A one-line :class:`UsvidError` when ``--workers`` is not in 1 .. :func:`max_workers`."""
    if workers is None:
        return
    hi, why = max_workers()
    if not 1 <= workers <= hi:
        raise UsvidError(f"--workers must be in 1..{hi} on this machine ({why}; got "
                         f"{workers})")


def _quiet_dask() -> Callable[[], None]:
    """Silence the ``distributed`` loggers of this process (their errors become the command's
    one error line); returns the function restoring them."""
    saved = {}
    for name in ("distributed", "tornado", "bokeh", "asyncio"):
        lg = logging.getLogger(name)
        saved[name] = lg.level
        lg.setLevel(logging.CRITICAL + 1)

    def restore() -> None:
        for name, level in saved.items():
            logging.getLogger(name).setLevel(level)
    return restore


@contextmanager
def _workers_quiet() -> Iterator[None]:
    """Processes started inside (the local workers) get /dev/null as their standard error: a
    Ctrl-C from the terminal reaches the whole process group, and a worker would print its
    KeyboardInterrupt traceback there (the command, which gets the same Ctrl-C, stops them and
    reports once; a task's error comes back to it through Dask, never through the worker's
    stderr). This process's own standard error is back when the workers are up."""
    sys.stderr.flush()
    saved = os.dup(2)
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)
        os.close(devnull)


@contextmanager
def _sigint_ignored() -> Iterator[None]:
    """SIGINT ignored while the cluster shuts down after a first Ctrl-C (a second one would
    leave it half closed). Outside the main thread: nothing to do."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


def _local_cluster(n: int) -> Any:
    """A cluster of ``n`` single-threaded worker processes listening on 127.0.0.1 only, with
    no HTTP server (no dashboard) in the scheduler or the workers."""
    from distributed import Nanny, SpecCluster

    silent = logging.CRITICAL + 1
    worker = {"cls": Nanny, "options": {
        "nthreads": 1, "host": "127.0.0.1", "protocol": "tcp://", "dashboard": False,
        "dashboard_address": None, "silence_logs": silent, "memory_limit": 0,
        "worker_class": _quiet.QuietWorker}}
    scheduler = {"cls": _quiet.QuietScheduler, "options": {
        "host": "127.0.0.1", "port": 0, "protocol": "tcp://", "dashboard": False,
        "dashboard_address": None}}
    before = set(SpecCluster._instances)
    try:
        with _workers_quiet():
            return SpecCluster(scheduler=scheduler, workers={i: worker for i in range(n)},
                               silence_logs=silent)
    except BaseException:  # (Ctrl-C during the start): close what was started, quietly
        for c in set(SpecCluster._instances) - before:
            SpecCluster._instances.discard(c)  # (else Dask's atexit hook closes it, loudly)
            _close(None, c)
        with _workers_quiet():  # the start's failed tasks, collected now: asyncio logs them
            gc.collect()
        raise


@contextmanager
def connect(scheduler: str | None = None, workers: int | None = None) -> Iterator[Any]:
    """A ``distributed.Client``: to the scheduler at ``scheduler`` (``tcp://host:8786``,
    checked by :func:`check_scheduler_address`), else to a new local cluster of ``workers``
    single-threaded processes (default: one per core; at most :func:`max_workers`). Closed
    (and the local cluster shut down) on exit, also on Ctrl-C."""
    from distributed import Client

    if scheduler and workers is not None:
        raise UsvidError("--workers applies to a local cluster; with --scheduler the "
                         "cluster's own workers run the tasks")
    address = check_scheduler_address(scheduler) if scheduler else None
    check_workers(workers)
    restore = _quiet_dask()
    cluster = client = None
    clean = False
    try:
        if address is not None:
            try:
                client = Client(address, timeout=f"{CONNECT_TIMEOUT_S}s")
            except (OSError, TimeoutError, ValueError) as exc:
                reason = " ".join(str(exc).split()) or type(exc).__name__
                raise UsvidError(f"--scheduler {address}: cannot connect to a Dask scheduler "
                                 f"there ({reason[:200]})") from None
        else:
            cluster = _local_cluster(workers or cores())
            client = Client(cluster)
        yield client
        clean = True
    finally:
        _close(client, cluster)
        if clean:  # (after an error or Ctrl-C the process is on its way out: Dask's late
            restore()  # log lines of its shut-down stay silent)


def _close(client: Any, cluster: Any) -> None:
    """Close the client and the local cluster (either may be None), quietly; a second Ctrl-C
    during the shut-down is ignored (the first one is being handled)."""
    with _sigint_ignored(), _workers_quiet():
        for obj in (client, cluster):
            if obj is None:
                continue
            try:
                obj.close()
            except Exception:  # noqa: BLE001 - shutting down after an error: that is reported
                pass


class TaskFailed(UsvidError):
    """A task of :func:`map_ordered` failed on a worker with an error that is not a
    :class:`UsvidError` (the message names the task and the error)."""


def map_ordered(client: Any, fn: Callable[..., Any], args: Sequence[tuple[Any, ...]], *,
                progress: bool = True, label: str = "tasks") -> list[Any]:
    """``[fn(*a) for a in args]`` as Dask tasks on ``client``, results in the order of ``args``.
    A task's :class:`UsvidError` is raised as it is; any other error of a task is one
    :class:`TaskFailed` line naming the task (Dask prints nothing). Each result is fetched as
    soon as its task ends and then released on the workers, so their memory stays flat however
    many tasks there are. With ``progress`` a bar on stderr (a terminal) counts finished
    tasks."""
    from distributed import as_completed

    futures = [client.submit(fn, *a, pure=False) for a in args]
    index = {f.key: i for i, f in enumerate(futures)}
    out: list[Any] = [None] * len(futures)
    done = as_completed(futures)
    del futures  # a result leaves the workers' memory once fetched (fut.release below)

    def fetch(fut: Any) -> None:
        i = index[fut.key]
        try:
            out[i] = fut.result()
        except UsvidError:
            raise
        except Exception as exc:  # noqa: BLE001 - a worker's failure: one line, not a trace
            text = " ".join(str(exc).split())[:300] or "no message"
            raise TaskFailed(f"{label} task {i + 1} of {len(out)} failed on a worker: "
                             f"{type(exc).__name__}: {text}") from None
        fut.release()

    if progress and sys.stderr.isatty():
        from rich.console import Console
        from rich.progress import Progress

        with Progress(console=Console(stderr=True), transient=True) as bar:
            task = bar.add_task(label, total=len(out))
            for fut in done:
                fetch(fut)
                bar.advance(task)
    else:
        for fut in done:
            fetch(fut)
    return out
