"""``t2m sim ...``: simulator commands. ``t2m sim demo`` runs a task's reference skeleton
(:func:`t2m_core.demo.run_demo`) and exits 1 when the task's goal is not reached.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import typer

from t2m_core.atomic_files import ensure_writable_directory, write_json_atomic


def resolve_simulator(name: str, options: dict[str, Any] | None = None) -> Any:
    """Build the simulator plugin ``name`` through the plugin registry."""
    from t2m_core.registry import get_registry

    return get_registry().create("simulator", name, options or {})


def demo(
    task_id: Annotated[str, typer.Option("--task", help="Task id, e.g. task0 (see `t2m tasks`).")],
    seed: Annotated[int, typer.Option("--seed", help="Reset seed.")] = 0,
    out: Annotated[Path, typer.Option("--out", help="Directory for video.mp4 and result.json.")] = Path("sim-demo"),
    sim: Annotated[str, typer.Option("--sim", help="Simulator plugin (see `t2m list-plugins`).")] = "mujoco",
    as_json: Annotated[bool, typer.Option("--json", help="Also print result.json on stdout.")] = False,
) -> None:
    """Execute a task's reference skeleton with sampled parameters and record a video.

    Exits 1 when the goal is not reached (result.json and the video are still written)."""
    from rich.console import Console

    from t2m_core.demo import run_demo
    from t2m_core.tasks import load_task

    console = Console(stderr=True)
    task = load_task(task_id)
    simulator = resolve_simulator(sim)
    ensure_writable_directory(out)
    try:
        with console.status(f"{sim}: searching and replaying {task.id} seed {seed}..."):
            result = run_demo(simulator, task, seed, out)
    finally:
        simulator.close()
    write_json_atomic(out / "result.json", result)
    verdict = "[green]goal reached[/]" if result["success"] else f"[red]failed[/]: {result['failure']}"
    console.print(f"{task.id} seed {seed}: {verdict} ({result['executions']} executions, {result['seconds']} s) -> {out}")
    if as_json:
        typer.echo(json.dumps(result, indent=2))
    if not result["success"]:
        raise typer.Exit(1)


def register(app: typer.Typer) -> None:
    """Add ``t2m sim`` to the root app."""
    sim_app = typer.Typer(help="Simulator commands.", no_args_is_help=True)
    sim_app.command("demo")(demo)
    app.add_typer(sim_app, name="sim")
