"""Results of a process pool as they finish, with Ctrl-C stopping the whole pool at once."""

from __future__ import annotations

from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Any, Callable, Iterable, Iterator


def as_finished(pool: ProcessPoolExecutor, fn: Callable[[Any], Any], items: Iterable[Any]) -> Iterator[Any]:
    """Submits ``fn(item)`` for every item and yields the results in the order they finish. On
    any exception (Ctrl-C included) the tasks not started are cancelled and the ones in flight
    stopped, so the pool's shutdown does not wait for them."""
    futures = [pool.submit(fn, item) for item in items]
    try:
        for f in as_completed(futures):
            yield f.result()
    except BaseException:
        for f in futures:
            f.cancel()
        # (`_processes` is private: the executor offers no public way to stop a running task)
        for p in list((getattr(pool, "_processes", None) or {}).values()):
            p.terminate()
        raise
