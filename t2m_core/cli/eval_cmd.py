"""``t2m eval``: the episode grid of planners × tasks × seeds (a thin layer over :mod:`t2m_core.evaluation`)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from t2m_core.atomic_files import ensure_writable_directory
from t2m_core.cli.executor_flags import AddressFlag, ExecutorFlag, task_status
from t2m_core.errors import T2MError


def evaluate(
    out: Annotated[Path, typer.Option("--out", help="Evaluation directory (one run directory per episode, the tables).")],
    planners: Annotated[str, typer.Option("--planners", help="Comma-separated task planners.")] = "hybrid,shooting,greedy-search,saycan-gs,innermono-gs",
    tasks: Annotated[str, typer.Option("--tasks", help="Comma-separated task ids, or all.")] = "all",
    seeds: Annotated[str, typer.Option("--seeds", help="Seed indices: 0-9 or 0,3,5 (base seed = index x 1000).")] = "0-9",
    workers: Annotated[int | None, typer.Option("--workers", min=1, help="Parallel episodes (default: 1 locally, one per CPU of a Ray cluster).")] = None,
    executor: ExecutorFlag = "local",
    address: AddressFlag = None,
    overrides: Annotated[list[str] | None, typer.Option("--set", help="Config override for every episode (repeatable).")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the results table as JSON on stdout.")] = False,
) -> None:
    """Run (or finish running) every episode of the grid and write results.md / .json / .csv and a
    plot of success per task and planner beside the paper's figures. With --executor ray the
    episodes run on a Ray cluster, whose nodes must all see --out."""
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from t2m_core.evaluation import episode_rows, finished, grid, parse_seed_indices, run_grid, summarise, write_tables
    from t2m_core.executors import make_executor
    from t2m_core.registry import get_registry
    from t2m_core.tasks import task_ids

    registry = get_registry()
    planner_names = [registry.get("task_planner", p.strip()).name for p in planners.split(",") if p.strip()]
    task_list = list(task_ids()) if tasks == "all" else [t.strip() for t in tasks.split(",") if t.strip()]
    unknown = [t for t in task_list if t not in task_ids()]
    if unknown:
        raise T2MError(f"unknown task(s) {', '.join(unknown)}", f"use task ids from `t2m tasks`: {', '.join(task_ids())}")
    episodes = grid(planner_names, task_list, parse_seed_indices(seeds))
    console = Console(stderr=True)
    ensure_writable_directory(out)
    columns = (TextColumn("[bold]episodes[/]"), BarColumn(), MofNCompleteColumn(), TextColumn("{task.fields[tasks]}"), TimeElapsedColumn())
    with (
        make_executor(executor, workers=workers or (1 if executor == "local" else 0), address=address) as pool,
        Progress(*columns, console=console) as bar,
    ):
        kept = sum(finished(episode, out) is not None for episode in episodes)  # a resumed grid starts where it stopped
        task = bar.add_task("episodes", total=len(episodes), completed=kept, tasks="")

        def show(episode, result) -> None:
            verdict = "[green]success[/]" if result["success"] else f"[red]{result['failure_type']}[/]"
            bar.console.print(f"{episode.planner} {episode.task} seed {episode.seed_index}: {verdict} ({result['timings']['total']:.0f} s)")
            bar.advance(task)

        def status(counts) -> None:
            bar.update(task, tasks=task_status(counts.running, counts.failed, counts.retried))

        results = run_grid(episodes, out, overrides or [], executor=pool, on_result=show, on_status=status)
        described = pool.describe()
    rows = summarise(results)
    write_tables(rows, out, described, episode_rows(results))
    console.print((out / "results.md").read_text(), highlight=False)
    if as_json:
        typer.echo(json.dumps(rows, indent=2))


def register(app: typer.Typer) -> None:
    """Add ``t2m eval`` to the root app."""
    app.command("eval")(evaluate)
