"""The flags that choose where the tasks of ``t2m datagen`` and ``t2m eval`` run, and the task counts
their progress views show (docs/guide/scaling.md)."""

from __future__ import annotations

from typing import Annotated

import typer

ExecutorFlag = Annotated[
    str,
    typer.Option("--executor", help='Where tasks run: local (processes on this machine) or ray (a Ray cluster; pip install "text2motion[ray]").'),
]
AddressFlag = Annotated[
    str | None,
    typer.Option("--address", help="Ray cluster to join: auto, HOST:PORT or ray://HOST:10001 (default: a private Ray instance on this machine)."),
]


def task_status(running: int, failed: int, retried: int) -> str:
    """``"2 running"``, ``"1 running, 1 failed, 2 retried"``: what the tasks in flight are doing."""
    parts = [f"{running} running"]
    if failed:
        parts.append(f"[red]{failed} failed[/]")
    if retried:
        parts.append(f"[yellow]{retried} retried[/]")
    return ", ".join(parts)
