"""``t2m show``: what a run or an evaluation directory records, in words (a thin layer over
:mod:`t2m_core.run_records`)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from t2m_core.errors import T2MError


def show(
    directory: Annotated[Path, typer.Argument(help="A run directory (`t2m run --out`) or an evaluation directory (`t2m eval --out`).")],
    failures_only: Annotated[bool, typer.Option("--failures", help="Evaluation directories: list only the failed episodes.")] = False,
) -> None:
    """Replay a run directory's plan tree (goal, shooting candidates, greedy steps, backtracks,
    executed skills) and its outcome; for an evaluation directory, print its results table and why
    each episode failed."""
    from rich.console import Console
    from rich.markup import escape

    from t2m_core.cli.plan_tree_view import render_event
    from t2m_core.run_records import episode_results, read_plan_tree, read_result

    console = Console(highlight=False, soft_wrap=True)
    if (directory / "plan_tree.jsonl").exists() or (directory / "result.json").exists():
        result = read_result(directory)
        if result is not None:
            console.print(f"[bold]{result.get('task')}[/] seed {result.get('seed')}, {result.get('planner')}: {escape(str(result.get('instruction')))}")
        for event in read_plan_tree(directory):
            render_event(console, event)
        if result is None:
            console.print("[yellow]no result.json: the episode was killed before it ended[/]")
        elif result.get("success"):
            console.print(f"[green]goal reached[/] ({_cost(result)})")
        else:
            console.print(f"{_verdict(result)}; subgoal completion {result.get('subgoal_completion', 0.0):.2f} ({_cost(result)})")
        return
    episodes = episode_results(directory)
    if not episodes:
        raise T2MError(f"{directory} holds neither a run record nor finished evaluation episodes",
                       "pass the --out directory of `t2m run` or `t2m eval`")
    if not failures_only and (directory / "results.md").exists():
        console.print((directory / "results.md").read_text(encoding="utf-8"))
    for path, result in episodes:
        if failures_only and result.get("success"):
            continue
        verdict = "[green]success[/]" if result.get("success") else _verdict(result)
        console.print(f"{path.relative_to(directory)}: {verdict} (plan of {len(result.get('plan') or [])}, "
                      f"{len(result.get('executed') or [])} executed)")


def _verdict(result: dict) -> str:
    """A failed episode in one line of console markup: its failure type and reason, or the error that stopped it."""
    from rich.markup import escape

    if result.get("error"):
        return f"[red]stopped by an error[/]: {escape(str(result['error']))}"
    if result.get("interrupted"):
        return "[yellow]interrupted[/] (Ctrl-C)"
    return f"[red]{result.get('failure_type')}[/]: {escape(str(result.get('failure')))}"


def _cost(result: dict) -> str:
    timings = result.get("timings") or {}
    return f"{result.get('llm_calls')} language-model calls, {result.get('stap_calls')} STAP plans, {timings.get('total', 0.0):.0f} s"


def register(app: typer.Typer) -> None:
    """Add ``t2m show`` to the root app."""
    app.command("show")(show)
