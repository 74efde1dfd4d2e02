"""The Ray executor: tasks run on the workers of a Ray cluster, or of a private Ray instance on this
machine (docs/guide/scaling.md). Imported only when ``--executor ray`` is chosen."""

from __future__ import annotations

import os
import uuid
from collections import deque
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import ray
from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

from t2m_core.errors import T2MError
from t2m_core.executors.base import Executor, Item, Result, TaskCounts, TaskTracker, WorkerLostError

FORWARDED_SETTINGS = ("T2M_PLUGINS", "T2M_DISABLE_PLUGIN_AUTOLOAD")
"""Settings that decide which components exist: the workers get the driver's values (a worker's own
environment is the one its node was started with)."""


class RayExecutor(Executor):
    """Tasks on Ray workers, one CPU each, at most ``workers`` at once.

    Joins the cluster at ``address``, or starts a private Ray instance on this machine with
    ``workers`` CPUs when there is none; a process that already called ``ray.init`` keeps its own
    connection. Ray reruns a task whose worker died (``max_retries`` times); a task's own error is
    not retried (it would fail the same way).
    """

    name = "ray"

    def __init__(self, workers: int = 0, *, address: str | None = None, max_retries: int = 3) -> None:
        self.max_retries = max_retries
        self._owns_connection = not ray.is_initialized()
        self._private = self._owns_connection and address is None
        if self._owns_connection:
            _connect(workers, address)
        cpus = int(ray.cluster_resources().get("CPU", 0))
        if cpus < 1:
            self.close()
            raise T2MError(f"the Ray cluster at {address or 'this machine'} has no CPU for tasks", "add worker nodes with `ray start --address ...`")
        self.workers = workers or cpus

    def map(
        self,
        function: Callable[[Item], Result],
        items: Sequence[Item],
        *,
        on_status: Callable[[TaskCounts], None] | None = None,
    ) -> Iterator[tuple[Item, Result]]:
        tracker = TaskTracker(len(items), on_status)
        task = ray.remote(num_cpus=1, max_retries=self.max_retries, retry_exceptions=False)(_run_task)
        function_ref = ray.put(function)  # shipped once, not with every task
        pending = deque(range(len(items)))
        running: dict[ray.ObjectRef, int] = {}
        try:
            while running or (pending and tracker.accepting):
                # no more in flight than workers: --workers caps the cluster's share, and "running" is true
                while pending and tracker.accepting and len(running) < self.workers:
                    index = pending.popleft()
                    running[task.remote(function_ref, items[index])] = index
                tracker.running(len(running))
                ready, _ = ray.wait(list(running), num_returns=1)
                for ref in ready:
                    index = running.pop(ref)
                    try:
                        result = ray.get(ref)
                    except ray.exceptions.RayTaskError as error:
                        cause = error.cause if isinstance(error.cause, Exception) else error
                        tracker.failed(items[index], cause, running=len(running))
                        continue
                    except ray.exceptions.WorkerCrashedError:
                        tracker.failed(items[index], WorkerLostError(self.max_retries + 1), running=len(running))
                        continue
                    except ray.exceptions.RayError as error:  # a lost node or object: Ray already retried
                        tracker.failed(items[index], error, running=len(running))
                        continue
                    tracker.finished(running=len(running))
                    yield items[index], result
        finally:
            for ref in running:  # an interrupted driver: the cluster stops working for it
                ray.cancel(ref, force=True)
        tracker.raise_failure()

    def require_shared(self, directory: Path) -> None:
        if self._private:
            return  # every worker is on this machine
        from t2m_core import __version__

        probe = Path(directory).resolve() / f".t2m-shared-{uuid.uuid4().hex}"
        probe.write_text("")
        try:
            look = ray.remote(num_cpus=0, max_retries=self.max_retries)(_look)
            nodes = [node for node in ray.nodes() if node["Alive"] and node["Resources"].get("CPU")]
            answers = ray.get([
                look.options(scheduling_strategy=NodeAffinitySchedulingStrategy(node["NodeID"], soft=False)).remote(str(probe))
                for node in nodes
            ])
        finally:
            probe.unlink(missing_ok=True)
        blind = [node["NodeManagerAddress"] for node, (sees, _) in zip(nodes, answers) if not sees]
        if blind:
            raise T2MError(
                f"{probe.parent} is not visible from the Ray node(s) at {', '.join(blind)}",
                "put --out on a file system that every node mounts at the same path (docs/guide/scaling.md#where-outputs-live)",
            )
        other = sorted({f"{node['NodeManagerAddress']} runs t2m {version}" for node, (_, version) in zip(nodes, answers) if version != __version__})
        if other:
            raise T2MError(f"this driver runs t2m {__version__}, but {'; '.join(other)}", "install the same t2m on every node of the cluster")

    def close(self) -> None:
        if self._owns_connection and ray.is_initialized():
            ray.shutdown()
            self._owns_connection = False


def _connect(workers: int, address: str | None) -> None:
    arguments: dict[str, Any] = {"address": address}
    if address is None:  # "local": a private instance, never a cluster some other job started on this machine
        arguments = {"address": "local", "num_cpus": workers or None, "include_dashboard": False}
    forwarded = {name: os.environ[name] for name in FORWARDED_SETTINGS if name in os.environ}
    if forwarded:
        arguments["runtime_env"] = {"env_vars": forwarded}
    try:
        ray.init(**arguments)
    except ConnectionError as error:
        raise T2MError(
            f"cannot join the Ray cluster at {address}: {str(error).strip().splitlines()[0]}",
            "start one with `ray start --head` and pass the address it prints (--address auto on a node of the cluster); "
            "a cluster with token authentication also needs RAY_AUTH_MODE=token and its token in this environment",
        ) from None


def _run_task(function: Callable[[Any], Any], item: Any) -> Any:
    return function(item)


def _look(path: str) -> tuple[bool, str]:
    """Whether this node sees ``path``, and the t2m version installed here."""
    from t2m_core import __version__

    return os.path.exists(path), __version__
