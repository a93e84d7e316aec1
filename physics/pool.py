"""Parallel evaluation of a function over the rows of a batch on dask.distributed.

:class:`DaskPool` maps ``fn(payload, item)`` over n items and hands each result to
``on_result(k, result)`` as soon as it is done (completion order), so that a caller can journal
it before the rest of the batch returns; the returned list keeps the input order. The payload
(e.g. an objective holding its data) is shipped to the workers once (``scatter``, broadcast) and
reused by later batches. Workers are a local cluster of single-threaded processes, started on
first use and kept until :meth:`DaskPool.close`, or an existing scheduler's ``address``. With
``n_workers=0`` and no address the pool runs the items serially in this process.

A pool is quiet: the local cluster's HTTP server takes a free port (no "Port 8787 is already in
use" when another cluster runs), and closing releases the scattered payload, then the client,
then the cluster, with distributed's shutdown messages (workers leaving, scattered data lost,
streams closed) silenced, since they are routine there. The worker processes log only CRITICAL
messages (a heartbeat that finds the scheduler already closing is logged as an ERROR with a
traceback); a task that fails or a worker that dies still reaches the caller as the future's
exception. A pool left open is closed the same way at interpreter exit, before distributed's own
exit handlers run.

dask.distributed is imported only when a cluster is needed.
"""
from __future__ import annotations

import atexit
import contextlib
import logging
import operator
import weakref
from collections.abc import Callable, Iterator, Sequence
from typing import Any

from physics.errors import ParameterError, PoolError

__all__ = ["DaskPool", "map_serial"]


_OPEN: weakref.WeakSet[DaskPool] = weakref.WeakSet()      # pools with a client, closed at exit
_AT_EXIT: list[bool] = []                                      # whether _close_open_pools is registered


@contextlib.contextmanager
def _quiet_distributed() -> Iterator[None]:
    """Raise every ``distributed`` logger of this process to CRITICAL for the duration (restored after):
    what a shutdown logs (workers removed, scattered data lost, comms closed) is expected then."""
    names = ["distributed", *(n for n in logging.root.manager.loggerDict if n.startswith("distributed."))]
    loggers = [logging.getLogger(name) for name in names]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        for lg, level in zip(loggers, levels, strict=True):
            lg.setLevel(level)


def _close_open_pools() -> None:
    """At interpreter exit: close the pools still open, in an order distributed does not complain about."""
    for pool in list(_OPEN):
        with contextlib.suppress(Exception):
            pool.close()


def _close_at_exit(pool: DaskPool) -> None:
    """Track ``pool`` for :func:`_close_open_pools`, registered once, after distributed is imported, so
    that it runs before distributed's own exit handlers (atexit runs the last registered first)."""
    _OPEN.add(pool)
    if not _AT_EXIT:
        atexit.register(_close_open_pools)
        _AT_EXIT.append(True)


def map_serial(fn: Callable[[Any, Any], Any], payload: Any, items: Sequence[Any],
               on_result: Callable[[int, Any], None] | None = None) -> list[Any]:
    """``[fn(payload, item) for item in items]`` in this process, calling ``on_result(k, result)`` per item."""
    out = []
    for k, item in enumerate(items):
        out.append(fn(payload, item))
        if on_result is not None:
            on_result(k, out[-1])
    return out


class DaskPool:
    """A dask.distributed client for batches of ``fn(payload, item)``.

    address: a running scheduler (e.g. ``"tcp://host:8786"``); default None starts a local cluster
    of ``n_workers`` single-threaded worker processes on first use (``0`` = serial, no cluster).
    warm_up: a picklable function run once on every worker after connecting (e.g. to load compiled
    kernels, so that the first evaluation is not charged for it). Pickling a pool keeps only these
    settings, so an object that owns a pool can be shipped to the workers.
    """

    def __init__(self, address: str | None = None, *, n_workers: int = 2,
                 warm_up: Callable[[], None] | None = None) -> None:
        try:
            workers = -1 if isinstance(n_workers, bool) else operator.index(n_workers)
        except TypeError:
            workers = -1
        if workers < 0:
            raise ParameterError(f"n_workers must be an integer >= 0 (0 = serial in this process), got {n_workers!r}.")
        self.address, self.n_workers, self.warm_up = address, workers, warm_up
        self._client: Any = None
        self._cluster: Any = None
        self._remote: Any = None
        self._payload: weakref.ref[Any] | None = None

    @property
    def parallel(self) -> bool:
        """Whether :meth:`map_rows` uses dask (an address, or ``n_workers >= 1``)."""
        return self.address is not None or self.n_workers > 0

    @property
    def cluster(self) -> Any:
        """The local cluster this pool started, or None (serial, not started yet, or an address)."""
        return self._cluster

    @property
    def scheduler_address(self) -> str | None:
        """The address of the scheduler batches run on (``address``, or the started local cluster's), so
        another pool can share its workers; None when serial or not started yet."""
        if self.address is not None:
            return self.address
        return None if self._cluster is None else str(self._cluster.scheduler_address)

    def _get_client(self) -> Any:
        if self._client is None:
            from distributed import Client, LocalCluster
            if self.address is not None:
                self._client = Client(self.address)
            else:
                try:
                    self._cluster = LocalCluster(n_workers=self.n_workers, threads_per_worker=1, processes=True,
                                                 dashboard_address="127.0.0.1:0", silence_logs=logging.CRITICAL)
                except RuntimeError as exc:
                    raise PoolError(
                        f"Could not start a local dask cluster of n_workers={self.n_workers} ({exc}). Worker "
                        "processes are spawned and import your script: put the script's code under "
                        "`if __name__ == \"__main__\":`, or evaluate serially with n_workers=0."
                    ) from exc
                self._client = Client(self._cluster)
            _close_at_exit(self)
            if self.warm_up is not None:
                self._client.run(self.warm_up)
        return self._client

    def _scattered(self, client: Any, payload: Any) -> Any:
        """The payload's future on the workers; scattered once per payload object."""
        if self._remote is None or self._payload is None or self._payload() is not payload:
            self._remote = client.scatter(payload, broadcast=True, hash=False)
            try:
                self._payload = weakref.ref(payload)
            except TypeError:          # not weak-referenceable: scatter again next time
                self._payload = None
        return self._remote

    def map_rows(self, fn: Callable[[Any, Any], Any], payload: Any, items: Sequence[Any],
                 on_result: Callable[[int, Any], None] | None = None) -> list[Any]:
        """``[fn(payload, item) for item in items]`` on the workers (serially when not :attr:`parallel`).

        fn must be picklable (a module-level function). on_result(k, result) is called for each item
        k as soon as it is done (completion order); the list returned keeps the input order.
        Exceptions raised by fn propagate (make fn record expected failures instead).
        """
        items = list(items)
        if not self.parallel or not items:
            return map_serial(fn, payload, items, on_result)
        from distributed import as_completed
        client = self._get_client()
        remote = self._scattered(client, payload)
        futures = client.map(fn, [remote] * len(items), items, pure=False)
        index = {f.key: k for k, f in enumerate(futures)}
        out: list[Any] = [None] * len(items)
        for fut in as_completed(futures):
            k = index[fut.key]
            out[k] = fut.result()
            if on_result is not None:
                on_result(k, out[k])
        return out

    def close(self) -> None:
        """Disconnect, and shut down the local cluster if this pool started one: the scattered payload is
        released, then the client closed, then the cluster, with distributed's shutdown messages silenced."""
        client, cluster, remote = self._client, self._cluster, self._remote
        self._client = self._cluster = self._remote = self._payload = None
        _OPEN.discard(self)
        if client is None and cluster is None:
            return
        with _quiet_distributed():
            if remote is not None and client is not None:
                with contextlib.suppress(Exception):
                    client.cancel(remote)
            if client is not None:
                client.close()
            if cluster is not None:
                cluster.close()

    def __enter__(self) -> DaskPool:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state["_client"] = state["_cluster"] = state["_remote"] = state["_payload"] = None
        return state

    def __del__(self) -> None:  # pragma: no cover - best effort at interpreter exit
        try:
            self.close()
        except Exception:
            pass
