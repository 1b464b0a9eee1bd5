"""The Dask scheduler and worker of a local cluster without an HTTP server.

Dask's scheduler starts an HTTP server (the dashboard's, and health/metrics routes) on port 8787
even when no dashboard is asked for, and every worker one on a port of its own; a local cluster
of usvid needs neither (its tasks report through the client). :class:`QuietScheduler` and
:class:`QuietWorker` keep the routing table Dask builds but listen nowhere. They are made on
first use (importing this module does not import ``distributed``: the in-process Monte-Carlo
path never loads it); a worker process unpickles ``usvid.scale._quiet.QuietWorker`` by name.
"""

from __future__ import annotations

from typing import Any

#: The classes made on first use.
_NAMES = ("QuietScheduler", "QuietWorker")


def _make(name: str) -> type:
    from distributed import Scheduler, Worker
    from distributed.http.routing import RoutingApplication

    def start_http_server(self: Any, routes: Any, dashboard_address: Any,
                          default_port: int = 0, ssl_options: Any = None) -> None:
        """Build the routing table (Dask reads it) and serve it nowhere."""
        self.http_application = RoutingApplication(routes)

    base = Scheduler if name == "QuietScheduler" else Worker
    cls = type(name, (base,), {"start_http_server": start_http_server, "__module__": __name__,
                               "__doc__": f"A Dask {base.__name__.lower()} without an HTTP "
                                          "server (no dashboard, no port)."})
    return cls


def __getattr__(name: str) -> type:
    """``QuietScheduler`` / ``QuietWorker``, made once on first use (PEP 562)."""
    if name in _NAMES:
        globals()[name] = cls = _make(name)
        return cls
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
