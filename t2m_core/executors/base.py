"""The interface every executor implements, and the bookkeeping of one batch of tasks."""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Self, TypeVar

from t2m_core.errors import T2MError

Item = TypeVar("Item")
Result = TypeVar("Result")


@dataclass
class TaskCounts:
    """Where the tasks of one :meth:`Executor.map` call stand (what the progress view shows).

    Attributes:
        total: tasks submitted to the map.
        done: finished with a result.
        running: in flight on a worker.
        failed: raised an error, or lost their worker more often than the retries allow.
        retried: rerun because their worker process died.
    """

    total: int
    done: int = 0
    running: int = 0
    failed: int = 0
    retried: int = 0


class WorkerLostError(T2MError):
    """A task whose worker process died more often than the executor retries it."""

    def __init__(self, deaths: int) -> None:
        super().__init__(
            f"the worker process running the task died {deaths} times",
            "a task that kills its process (out of memory, a crash in native code) dies the same way each time: "
            "rerun the command with --executor local --workers 1 to see where",
        )


class TaskTracker:
    """Counts one batch's tasks, reports every change, and keeps the first failure.

    After a failure an executor submits nothing new and lets the running tasks finish (their
    outputs are kept on disk); :meth:`raise_failure` then re-raises the failure, so the command
    stops with that error and rerunning it resumes.
    """

    def __init__(self, total: int, on_status: Callable[[TaskCounts], None] | None) -> None:
        self.counts = TaskCounts(total)
        self.failure: BaseException | None = None
        self._on_status = on_status

    @property
    def accepting(self) -> bool:
        """Whether new tasks may start (no task has failed)."""
        return self.failure is None

    def running(self, count: int) -> None:
        self.counts.running = count
        self._report()

    def finished(self, *, running: int) -> None:
        """One task finished; ``running`` are still in flight."""
        self.counts.done += 1
        self.counts.running = running
        self._report()

    def retried(self, count: int = 1) -> None:
        self.counts.retried += count
        self._report()

    def failed(self, item: Any, error: BaseException, *, running: int) -> None:
        """The task of ``item`` failed with ``error``; ``running`` are still in flight."""
        self.counts.failed += 1
        self.counts.running = running
        if self.failure is None:
            error.add_note(f"while running {item!r}")
            self.failure = error
        self._report()

    def raise_failure(self) -> None:
        """Re-raise the first failure, if any, noting what was kept."""
        if self.failure is not None:
            counts = self.counts
            self.failure.add_note(
                f"{counts.failed} of {counts.total} tasks failed and {counts.done} finished; finished outputs are "
                "kept: rerun the same command to resume"
            )
            raise self.failure

    def _report(self) -> None:
        if self._on_status is not None:
            self._on_status(self.counts)


class Executor:
    """Runs tasks ``function(item)`` on workers and yields their results as they finish.

    A task must be a module-level function (or a :func:`functools.partial` of one) of picklable
    arguments that writes its own output atomically: a task can run in any process, more than once
    (a retry after its worker died), or not at all (a resumed job skips it).

    Attributes:
        name: ``local`` or ``ray``.
        workers: tasks run at once.
    """

    name: str = ""
    workers: int = 1

    def map(
        self,
        function: Callable[[Item], Result],
        items: Sequence[Item],
        *,
        on_status: Callable[[TaskCounts], None] | None = None,
    ) -> Iterator[tuple[Item, Result]]:
        """Run ``function`` on every item; yield ``(item, result)`` in the order tasks finish.

        ``on_status`` hears every change of the counts. A task whose worker process dies is run
        again, up to the executor's ``max_retries``. After the first task that fails, no new task
        starts; the running ones finish, then the failure is raised (with a note naming its item).
        """
        raise NotImplementedError

    def require_shared(self, directory: Path) -> None:
        """Check that every worker sees ``directory`` (where the tasks write their outputs).

        Raises:
            T2MError: a worker that cannot see it, naming where it runs and the fix.
        """

    def describe(self) -> dict[str, Any]:
        """What a manifest records about the executor: ``{"name": ..., "workers": ...}``."""
        return {"name": self.name, "workers": self.workers}

    def close(self) -> None:
        """Release the workers (and a Ray instance this executor started)."""

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()
