"""Executors: where the chunk tasks of ``t2m datagen`` and the episode tasks of ``t2m eval`` run
(docs/guide/scaling.md).

Two implementations behind one interface (:class:`~t2m_core.executors.base.Executor`): ``local``,
a pool of worker processes on this machine (the default), and ``ray``, the workers of a Ray cluster
(``pip install "text2motion[ray]"``). A task is a pure function of its item that writes its own
output atomically, so the files on disk do not depend on which executor ran it::

    with make_executor("ray", workers=0, address="auto") as executor:
        for item, result in executor.map(function, items, on_status=show):
            ...

Ray is imported only by :func:`make_executor` ``("ray", ...)``.
"""

from __future__ import annotations

from t2m_core.errors import T2MError
from t2m_core.executors.base import Executor, TaskCounts
from t2m_core.executors.local import LocalExecutor

EXECUTORS: tuple[str, ...] = ("local", "ray")
"""Executor names, the values of ``--executor``."""
DEFAULT_MAX_RETRIES = 3
"""Times a task whose worker process died is run again (Ray's default for tasks)."""
RAY_EXTRA_LINE = 'Ray is not installed: --executor ray needs the ray extra, pip install "text2motion[ray]"'

__all__ = ["EXECUTORS", "Executor", "LocalExecutor", "TaskCounts", "make_executor"]


def make_executor(name: str, *, workers: int, address: str | None = None, max_retries: int = DEFAULT_MAX_RETRIES) -> Executor:
    """The executor called ``name``, ready to run tasks (close it, or use it as a context manager).

    Args:
        name: ``local`` or ``ray``.
        workers: tasks run at once; for Ray, 0 means one per CPU of the cluster.
        address: the Ray cluster to join (``auto``, ``HOST:PORT``, ``ray://HOST:10001``); ``None``
            starts a private Ray instance on this machine. Only for ``ray``.
        max_retries: runs of a task whose worker died, beyond the first.

    Raises:
        T2MError: an unknown name, an address for the local executor, or Ray not installed.
    """
    if name not in EXECUTORS:
        raise T2MError(f"unknown executor {name!r}", f"use one of: {', '.join(EXECUTORS)}")
    if name == "local":
        if address is not None:
            raise T2MError("--address names a Ray cluster, but the executor is local", "add --executor ray, or drop --address")
        return LocalExecutor(workers, max_retries=max_retries)
    try:
        from t2m_core.executors.ray_executor import RayExecutor
    except ModuleNotFoundError as error:
        if error.name and error.name.split(".")[0] == "ray":
            raise T2MError(RAY_EXTRA_LINE) from None
        raise
    return RayExecutor(workers, address=address, max_retries=max_retries)
