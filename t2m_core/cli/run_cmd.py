"""``t2m run``: one Text2Motion episode (a thin layer over :func:`t2m_core.episode.run_episode`)."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Annotated

import typer

from t2m_core.atomic_files import ensure_writable_directory


def run(
    config_files: Annotated[list[Path] | None, typer.Option("--config", "-c", help="Run config file(s), merged in order.")] = None,
    planner: Annotated[str | None, typer.Option("--planner", help="Task planner (default hybrid).")] = None,
    sim: Annotated[str | None, typer.Option("--sim", help="Simulator (default mujoco).")] = None,
    llm: Annotated[str | None, typer.Option("--llm", help="Language model (default: the embedded local model).")] = None,
    task_id: Annotated[str | None, typer.Option("--task", help="Task id (see `t2m tasks`).")] = None,
    seed: Annotated[int | None, typer.Option("--seed", min=0, help="Base seed of the scene.")] = None,
    instruction: Annotated[str | None, typer.Option("--instruction", help="Replace the task's instruction (judged by the predicted goal).")] = None,
    out: Annotated[Path | None, typer.Option("--out", help="Run directory (default: $T2M_RUNS_DIR/<task>-seed<N>-<time>).")] = None,
    overrides: Annotated[list[str] | None, typer.Option("--set", help="Config override a.b=c (repeatable).")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print result.json on stdout.")] = False,
) -> None:
    """Predict the instruction's goal, plan a skill sequence whose feasibility STAP verified, execute
    it closed loop in the simulator and check the goal. Exits 0 only when the goal is reached."""
    from rich.console import Console

    from t2m_core.cli.plan_tree_view import render_event
    from t2m_core.config.resolve import resolve_config
    from t2m_core.episode import run_episode
    from t2m_core.registry import get_registry

    console = Console(stderr=True)
    flags = {"planner": planner, "sim": sim, "llm": llm, "task": task_id, "seed": seed}
    config = resolve_config(config_files or (), flags=flags, overrides=overrides or (), registry=get_registry())
    directory = out or _default_directory(config.task, config.seed)
    ensure_writable_directory(directory)
    console.print(f"[bold]{config.task}[/] seed {config.seed}: {config.task_planner.name if config.task_planner else '-'} planner, "
                  f"{config.language_model.name} language model, {config.simulator.name} -> {directory}")
    try:
        result = run_episode(config, directory, instruction=instruction, on_event=lambda event: render_event(console, event))
    except KeyboardInterrupt:
        console.print(f"[yellow]interrupted[/]: what happened so far is in {directory}")
        raise typer.Exit(130) from None
    verdict = "[green]goal reached[/]" if result.success else f"[red]{result.failure_type}[/]: {result.failure}"
    console.print(f"{verdict} ({result.llm_calls} language-model calls, {result.stap_calls} STAP plans, {result.timings.total:.0f} s) -> {directory}")
    if as_json:
        typer.echo(json.dumps(result.as_dict(), indent=2))
    if not result.success:
        raise typer.Exit(1)


def _default_directory(task: str, seed: int) -> Path:
    from t2m_core.settings import runs_dir

    return runs_dir() / f"{task}-seed{seed}-{time.strftime('%Y%m%d-%H%M%S')}"


def register(app: typer.Typer) -> None:
    """Add ``t2m run`` to the root app."""
    app.command("run")(run)
