"""The local executor: a pool of worker processes on this machine (the default)."""

from __future__ import annotations

import os
import sys
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool

from t2m_core.errors import T2MError
from t2m_core.executors.base import Executor, Item, Result, TaskCounts, TaskTracker, WorkerLostError


class LocalExecutor(Executor):
    """``workers`` processes of this machine; with one worker, tasks run in this process.

    A worker process that dies (killed, out of memory) breaks the whole pool: the pool is rebuilt
    and every task that was in it runs again, each at most ``max_retries`` more times. Each pool
    worker gets an equal share of this machine's cores for its math libraries
    (:func:`worker_threads`), so that the workers' torch and BLAS thread pools do not oversubscribe
    the cores.
    """

    name = "local"

    def __init__(self, workers: int = 1, *, max_retries: int = 3) -> None:
        if workers < 1:
            raise T2MError(f"the local executor needs at least one worker, got {workers}", "pass --workers 1 or more")
        self.workers = workers
        self.max_retries = max_retries

    def map(
        self,
        function: Callable[[Item], Result],
        items: Sequence[Item],
        *,
        on_status: Callable[[TaskCounts], None] | None = None,
    ) -> Iterator[tuple[Item, Result]]:
        tracker = TaskTracker(len(items), on_status)
        if self.workers == 1:
            yield from _in_this_process(function, items, tracker)
        else:
            yield from self._in_pool(function, items, tracker)
        tracker.raise_failure()

    def _in_pool(self, function: Callable[[Item], Result], items: Sequence[Item], tracker: TaskTracker) -> Iterator[tuple[Item, Result]]:
        pending = deque(range(len(items)))
        deaths = [0] * len(items)
        running: dict[Future, int] = {}
        pool = self._pool()
        try:
            while running or (pending and tracker.accepting):
                # two tasks per worker in flight: a worker never waits for the driver between tasks
                while pending and tracker.accepting and len(running) < 2 * self.workers:
                    index = pending.popleft()
                    running[pool.submit(function, items[index])] = index
                tracker.running(min(len(running), self.workers))
                done, _ = wait(running, return_when=FIRST_COMPLETED)
                lost: list[int] = []
                for future in done:
                    index = running.pop(future)
                    try:
                        result = future.result()
                    except BrokenProcessPool:
                        lost.append(index)
                        continue
                    except Exception as error:  # noqa: BLE001 - the task's own error, raised when the batch ends
                        tracker.failed(items[index], error, running=min(len(running), self.workers))
                        continue
                    tracker.finished(running=min(len(running), self.workers))
                    yield items[index], result
                if lost:  # a worker died and took the pool down with every task in it: rebuild, run them again
                    lost += running.values()
                    running.clear()
                    pool.shutdown(wait=True, cancel_futures=True)
                    pool = self._pool()
                    for index in sorted(lost, reverse=True):
                        deaths[index] += 1
                        if deaths[index] > self.max_retries:
                            tracker.failed(items[index], WorkerLostError(deaths[index]), running=0)
                        else:
                            pending.appendleft(index)
                            tracker.retried()
        finally:
            pool.shutdown(wait=True, cancel_futures=True)

    def _pool(self) -> ProcessPoolExecutor:
        """A fresh pool whose workers each get their :func:`worker_threads` share of the cores."""
        return ProcessPoolExecutor(max_workers=self.workers, initializer=limit_threads, initargs=(worker_threads(self.workers),))


def worker_threads(workers: int, cores: int | None = None) -> int:
    """Math-library threads per worker process: this machine's cores (``cores``; default
    ``os.cpu_count()``) shared equally among ``workers``, at least one."""
    return max(1, (cores or os.cpu_count() or 1) // workers)


def limit_threads(threads: int) -> None:
    """At most ``threads`` OpenMP/BLAS threads in this process, and as many torch threads when torch
    is already loaded (a forked worker inherits the parent's pool size). The pool workers'
    initialiser, and ``t2m train --threads``."""
    for name in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
        os.environ[name] = str(threads)
    torch = sys.modules.get("torch")
    if torch is not None:
        torch.set_num_threads(threads)


def _in_this_process(function: Callable[[Item], Result], items: Sequence[Item], tracker: TaskTracker) -> Iterator[tuple[Item, Result]]:
    """One task at a time in this process (nothing is pickled; a crash here is the command's own)."""
    for item in items:
        tracker.running(1)
        try:
            result = function(item)
        except Exception as error:  # noqa: BLE001 - re-raised by the caller once the batch ends
            tracker.failed(item, error, running=0)
            return
        tracker.finished(running=0)
        yield item, result
