"""Dask clients for the scale-out commands: a local cluster or an existing scheduler, and an
ordered map of tasks with a progress bar on stderr.

A local cluster has one single-threaded worker process per core (the simulation kernel runs
nogil numba code: processes avoid sharing one interpreter; each task sets numba to one thread).
"""

from __future__ import annotations

import logging
import os
import sys
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

from usvid.errors import UsvidError

__all__ = ["connect", "map_ordered"]


@contextmanager
def connect(scheduler: str | None = None, workers: int | None = None) -> Iterator[Any]:
    """A ``distributed.Client``: to the scheduler at ``scheduler`` (``tcp://host:8786``), else
    to a new local cluster of ``workers`` single-threaded processes (default: all cores).
    Closed (and the local cluster shut down) on exit."""
    from distributed import Client, LocalCluster

    if workers is not None and workers < 1:
        raise UsvidError(f"--workers must be >= 1 (got {workers})")
    if scheduler:
        try:
            client = Client(scheduler, timeout="10s")
        except (OSError, TimeoutError) as exc:
            raise UsvidError(f"--scheduler {scheduler}: cannot connect to a Dask scheduler "
                             f"there ({exc})") from None
        try:
            yield client
        finally:
            client.close()
        return
    n = workers or os.cpu_count() or 1
    cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                           dashboard_address=None, silence_logs=logging.ERROR)
    client = Client(cluster)
    try:
        yield client
    finally:
        client.close()
        cluster.close()


def map_ordered(client: Any, fn: Callable[..., Any], args: Sequence[tuple[Any, ...]], *,
                progress: bool = True, label: str = "tasks") -> list[Any]:
    """``[fn(*a) for a in args]`` as Dask tasks on ``client``, results in the order of ``args``
    (a task's exception is raised). Each result is fetched as soon as its task ends and then
    released on the workers, so their memory stays flat however many tasks there are. With
    ``progress`` a bar on stderr (a terminal) counts finished tasks."""
    from distributed import as_completed

    futures = [client.submit(fn, *a, pure=False) for a in args]
    index = {f.key: i for i, f in enumerate(futures)}
    out: list[Any] = [None] * len(futures)
    done = as_completed(futures)
    del futures  # a result leaves the workers' memory once fetched (fut.release below)
    if progress and sys.stderr.isatty():
        from rich.console import Console
        from rich.progress import Progress

        with Progress(console=Console(stderr=True), transient=True) as bar:
            task = bar.add_task(label, total=len(out))
            for fut in done:
                out[index[fut.key]] = fut.result()
                fut.release()
                bar.advance(task)
    else:
        for fut in done:
            out[index[fut.key]] = fut.result()
            fut.release()
    return out
