"""agents.pool.as_finished: results as they finish; a failure stops the whole pool at once."""

import multiprocessing
import time
from concurrent.futures import ProcessPoolExecutor

import pytest

from agents.pool import as_finished


def _task(item):
    kind, value = item
    if kind == "fail":
        raise ValueError(f"task {value} failed")
    time.sleep(value)
    return value


def test_results_come_in_the_order_they_finish():
    with ProcessPoolExecutor(max_workers=2, mp_context=multiprocessing.get_context("spawn")) as pool:
        assert list(as_finished(pool, _task, [("sleep", 5.0), ("sleep", 0.0)])) == [0.0, 5.0]


def test_a_failure_cancels_the_waiting_tasks_and_stops_the_running_ones():
    start = time.perf_counter()
    with pytest.raises(ValueError, match="task 1 failed"):
        with ProcessPoolExecutor(max_workers=2, mp_context=multiprocessing.get_context("spawn")) as pool:
            list(as_finished(pool, _task, [("sleep", 120.0), ("fail", 1), ("sleep", 120.0)]))
    # the pool's shutdown did not wait for the 120 s task in flight nor start the queued one
    assert time.perf_counter() - start < 60.0
