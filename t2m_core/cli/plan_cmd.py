"""``t2m plan``: plan a fixed skill sequence with the feasibility planner and, optionally, execute it
closed loop (:func:`t2m_core.closed_loop.execute_closed_loop`)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import typer

from t2m_core.atomic_files import ensure_writable_directory


def plan(
    skeleton: Annotated[str, typer.Option("--skeleton", help='Skill sequence, e.g. "pick(hook), pull(blue_box, hook)".')],
    task_id: Annotated[str | None, typer.Option("--task", help="Task id (see `t2m tasks`).")] = None,
    seed: Annotated[int | None, typer.Option("--seed", min=0, help="Reset seed.")] = None,
    feasibility: Annotated[str | None, typer.Option("--feasibility", help="Feasibility planner (default policy-cem).")] = None,
    sim: Annotated[str | None, typer.Option("--sim", help="Simulator plugin.")] = None,
    execute: Annotated[bool, typer.Option("--execute", help="Execute the skeleton closed loop in the simulator.")] = False,
    out: Annotated[Path | None, typer.Option("--out", help="Write plan.json (and with --execute result.json, video.mp4) here.")] = None,
    config_files: Annotated[list[Path] | None, typer.Option("--config", "-c", help="Run config file(s).")] = None,
    overrides: Annotated[list[str] | None, typer.Option("--set", help="Config override a.b=c (repeatable).")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the result as JSON on stdout.")] = False,
) -> None:
    """Optimise the parameters of a skill sequence from a task's initial scene and print each step's
    action, Q-values, OOD flag and success probability; with --execute, run it closed loop (re-planning
    the remaining skills after every executed one) and exit 1 unless every skill succeeds."""
    from rich.console import Console

    from t2m_core.components import build_component
    from t2m_core.config.resolve import resolve_config
    from t2m_core.domain.skills import parse_skeleton
    from t2m_core.registry import get_registry
    from t2m_core.tasks import load_task

    console = Console(stderr=True)
    flags = {"task": task_id, "seed": seed, "sim": sim}
    extra = [f"feasibility_planner.name={feasibility}"] if feasibility else []
    config = resolve_config(config_files or (), flags=flags, overrides=[*extra, *(overrides or [])], registry=get_registry())
    task = load_task(config.task)
    calls = parse_skeleton(skeleton, task.objects)
    if out is not None:
        ensure_writable_directory(out)
    simulator = build_component(config, "simulator")
    try:
        skills = build_component(config, "skills")
        planner = build_component(config, "feasibility_planner")
        reset = simulator.reset(task, seed=config.seed)
        objects = reset.state.object_names
        with console.status(f"{config.feasibility_planner.name}: planning {len(calls)} skills..."):
            first = planner.plan(reset.observation, list(calls), skills, objects)
        report: dict[str, Any] = {"task": task.id, "seed": config.seed, "accepted_seed": reset.accepted_seed, "skeleton": [str(c) for c in calls]}
        report["plan"] = _plan_rows(calls, first)
        report["p_success"] = first.p_success
        _print_plan(console, calls, first)
        if execute:
            report["execution"] = _execute(console, simulator, planner, skills, calls, objects, out, config, first)
    finally:
        simulator.close()
    if out is not None:
        from t2m_core.atomic_files import write_json_atomic

        write_json_atomic(out / ("result.json" if execute else "plan.json"), report)
    if as_json:
        typer.echo(json.dumps(report, indent=2))
    if execute and not report["execution"]["success"]:
        raise typer.Exit(1)


def _plan_rows(calls, plan) -> list[dict[str, Any]]:
    rows = []
    for t, call in enumerate(calls):
        rows.append({
            "skill": str(call),
            "action": [round(float(a), 4) for a in plan.actions[t]],
            "value": float(plan.values[t]),
            "q_members": [round(float(q), 4) for q in plan.q_members[t]] if plan.q_members is not None else None,
            "variance": float(plan.variances[t]) if plan.variances is not None else None,
            "ood": bool(plan.ood[t]),
        })
    return rows


def _print_plan(console, calls, plan) -> None:
    from rich.table import Table

    table = Table(title=f"plan: p_success {plan.p_success:.3f}", title_justify="left")
    for column in ("skill", "action (normalised)", "min Q", "Q members", "OOD"):
        table.add_column(column)
    for t, call in enumerate(calls):
        members = " ".join(f"{q:.2f}" for q in plan.q_members[t]) if plan.q_members is not None else "-"
        table.add_row(str(call), " ".join(f"{a:+.2f}" for a in plan.actions[t]), f"{plan.values[t]:.3f}", members, "yes" if plan.ood[t] else "no")
    console.print(table)


def _execute(console, simulator, planner, skills, calls, objects, out: Path | None, config, first) -> dict[str, Any]:
    import contextlib

    from t2m_core.closed_loop import execute_closed_loop

    recording = contextlib.nullcontext(None)
    if out is not None and config.output.video:
        from t2m_core.video import VideoWriter

        recording = VideoWriter(out / "video.mp4", fps=getattr(getattr(simulator, "options", None), "video_fps", 15))

    def show(step) -> None:
        verdict = "[green]success[/]" if step.result.success else f"[red]failed: {step.result.failure}[/]"
        console.print(
            f"{step.call}: action {' '.join(f'{a:+.2f}' for a in step.action)}, min Q {step.plan.values[0]:.3f}, "
            f"OOD {'yes' if step.plan.ood[0] else 'no'}, p_success of the rest {step.plan.p_success:.3f} -> {verdict}"
        )

    with recording as video:
        if video is not None:
            video.add(simulator.render())
            simulator.stream_frames(video.add)
        try:
            result = execute_closed_loop(simulator, planner, skills, calls, objects, on_step=show, closed_loop=config.run.closed_loop,
                                         replan_start=config.run.replan_start, retry_below=config.run.retry_below, accepted=first)
        finally:
            if video is not None:
                simulator.stream_frames(None)
    return {"success": result.success, "steps": [step.summary() for step in result.steps]}


def register(app: typer.Typer) -> None:
    """Add ``t2m plan`` to the root app."""
    app.command("plan")(plan)
