"""Running independent fitting tasks in parallel: local processes (joblib/loky) or a Dask
cluster, with results in input order. LGPR fits its clusters through :func:`run_tasks`."""
from __future__ import annotations

import socket
from typing import Any, Callable, Iterable, Sequence
from urllib.parse import urlsplit

__all__ = ["run_tasks", "connect_client", "DASK_CONNECT_TIMEOUT"]

DASK_CONNECT_TIMEOUT = "30s"
# s for the plain TCP check of a tcp:// scheduler address before a Client is made
DASK_REACH_TIMEOUT_S = 10.0


def _check_reachable(address: str) -> None:
    """Refuse a ``tcp://host:port`` scheduler nobody listens on before a ``distributed.Client``
    is made: a Client whose connection fails keeps its IO-loop thread for the life of the
    process (its constructor raises, so nothing can close it)."""
    parts = urlsplit(address if "://" in address else f"tcp://{address}")  # Dask's default
    if parts.scheme != "tcp":
        return              # other transports: the Client reports them itself
    try:
        port = parts.port
    except ValueError:      # a port that is not a number
        port = None
    if not parts.hostname or port is None:
        raise ValueError(f"cannot connect to the Dask scheduler {address}: not an address "
                         "(tcp://HOST:PORT)")
    try:
        socket.create_connection((parts.hostname, port), DASK_REACH_TIMEOUT_S).close()
    except OSError as e:
        raise ValueError(f"cannot connect to the Dask scheduler {address}: "
                         f"{e.strerror or type(e).__name__}") from e


def connect_client(address: str):
    """A ``distributed.Client`` of the scheduler at ``address`` (not the default client); a
    ValueError of one line if it cannot be reached."""
    try:
        from distributed import Client
    except ImportError as e:  # pragma: no cover - distributed is a dependency
        raise ValueError(f"a Dask scheduler needs the 'distributed' package: {e}") from e
    _check_reachable(address)
    try:
        return Client(address, timeout=DASK_CONNECT_TIMEOUT, set_as_default=False)
    except (OSError, ValueError, TypeError) as e:
        raise ValueError(f"cannot connect to the Dask scheduler {address}: "
                         f"{str(e).splitlines()[0] if str(e) else type(e).__name__}") from e


def run_tasks(func: Callable[..., Any], arg_tuples: Sequence[tuple], *, n_jobs: int = 1,
              dask_scheduler: str | None = None,
              on_result: Callable[[int, Any], None] | None = None) -> list[Any]:
    """Run ``func(*args)`` for every tuple, in order, through joblib; results in input order.

    ``n_jobs`` local loky processes (1: in this process), or the workers of the Dask cluster at
    ``dask_scheduler`` (joblib's ``dask`` backend through a ``distributed.Client``).
    ``on_result(i, result)`` is called as results arrive (in order), e.g. for progress.
    """
    from joblib import Parallel, delayed

    tasks = [delayed(func)(*a) for a in arg_tuples]
    results: list[Any] = []

    def collect(it: Iterable[Any]) -> None:
        for i, r in enumerate(it):
            results.append(r)
            if on_result is not None:
                on_result(i, r)

    if dask_scheduler:
        from joblib import parallel_config
        client = connect_client(dask_scheduler)
        try:
            with parallel_config(backend="dask", client=client, wait_for_workers_timeout=60):
                collect(Parallel(n_jobs=-1, return_as="generator")(tasks))
        finally:
            client.close()
        return results
    if n_jobs == 1 or len(tasks) <= 1:
        collect(t[0](*t[1], **t[2]) for t in tasks)
        return results
    collect(Parallel(n_jobs=n_jobs, return_as="generator")(tasks))
    return results
