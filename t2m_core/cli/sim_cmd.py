"""``t2m sim ...``: simulator commands. ``t2m sim demo`` runs a task's reference skeleton.

The demo is a check of a backend and its primitives, not a planner: for each skill of the task's
reference skeleton it samples parameters (the domain's heuristic action first, then its exploration
sampler: heuristic plus noise, sometimes uniform), executes them from a restored snapshot and keeps
the first that succeeds. When a skill exhausts its tries, the search backs up and samples an earlier
skill again (a bounded depth-first search, see :func:`search_skeleton`). The chosen actions are then replayed from a fresh
reset of the same seed, recording ``video.mp4``, and ``result.json`` is written.
"""

from __future__ import annotations

import json
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import typer

from t2m_core.atomic_files import write_json_atomic

TRIES_PER_SKILL = 25
"""Executions of one skill from a new start state before the search backs up."""
RETRIES_AFTER_BACKTRACK = 3
"""Executions of a skill revisited because a later skill exhausted its tries."""
MAX_EXECUTIONS = 600
"""Executions of the whole search before it gives up."""


@dataclass
class SkeletonSearch:
    """Result of :func:`search_skeleton`.

    Attributes:
        actions: ``(4,)`` normalised action of every skill that succeeded, in order.
        tries: executions spent on each skill of the skeleton (all visits).
        found: every skill succeeded.
        failures: failure reason -> count over all executions.
        executions: total primitive executions.
    """

    actions: list[np.ndarray] = field(default_factory=list)
    tries: list[int] = field(default_factory=list)
    found: bool = False
    failures: dict[str, int] = field(default_factory=dict)
    executions: int = 0


def resolve_simulator(name: str, options: dict[str, Any] | None = None) -> Any:
    """Build the simulator plugin ``name`` through the plugin registry."""
    from t2m_core.registry import get_registry

    return get_registry().create("simulator", name, options or {})


def search_skeleton(
    simulator: Any,
    skeleton: Sequence[Any],
    rng: np.random.Generator,
    *,
    tries_per_skill: int = TRIES_PER_SKILL,
    retries_after_backtrack: int = RETRIES_AFTER_BACKTRACK,
    max_executions: int = MAX_EXECUTIONS,
) -> SkeletonSearch:
    """Find parameters for every skill of ``skeleton`` (``SkillCall`` s) from the simulator's
    current state by sampling and snapshot-restored trials.

    A skill gets ``tries_per_skill`` executions from a new start state. When they all fail, the
    search backs up. If the failures were collisions with an object that an earlier skill of the
    skeleton moved (a box placed where the hook must sweep), it jumps back to that skill; otherwise
    to the previous one. A skill revisited this way gets ``retries_after_backtrack`` executions
    before the search backs up further, which keeps the search from growing exponentially."""
    from t2m_core.domain.primitives import get_primitive

    count = len(skeleton)
    result = SkeletonSearch(tries=[0] * count)
    snapshots = [simulator.get_state()]
    budget = [tries_per_skill] * count
    visit_tries = [0] * count
    blamed: list[dict[str, int]] = [{} for _ in range(count)]
    index = 0
    while 0 <= index < count and result.executions < max_executions:
        if visit_tries[index] >= budget[index]:
            target = _backjump_target(skeleton, index, blamed[index])
            for undone in range(target, index + 1):
                visit_tries[undone], budget[undone], blamed[undone] = 0, tries_per_skill, {}
            del snapshots[target + 1 :]
            del result.actions[target:]
            index = target
            if index < 0:
                break
            budget[index] = retries_after_backtrack
            continue
        call = skeleton[index]
        primitive = get_primitive(call.name)
        simulator.set_state(snapshots[index])
        state = simulator.geometric_state()
        first = result.tries[index] == 0
        action = (primitive.heuristic_action if first else primitive.exploration_action)(state, call.args, rng)
        visit_tries[index] += 1
        result.tries[index] += 1
        result.executions += 1
        outcome = simulator.execute(call.name, call.args, action)
        if outcome.success:
            result.actions.append(np.asarray(action, dtype=np.float64))
            snapshots.append(simulator.get_state())
            visit_tries[index] = 0
            index += 1
        else:
            result.failures[outcome.failure] = result.failures.get(outcome.failure, 0) + 1
            for contact in outcome.contacts:
                blamed[index][contact.body_b] = blamed[index].get(contact.body_b, 0) + 1
    result.found = index == count
    return result


def _backjump_target(skeleton: Sequence[Any], index: int, blamed: dict[str, int]) -> int:
    """The skill to sample again after skill ``index`` exhausted its tries: the latest earlier skill
    that moved the object the failures collided with most, else the previous skill (−1: none)."""
    if blamed:
        culprit = max(blamed, key=blamed.get)
        for earlier in range(index - 1, -1, -1):
            call = skeleton[earlier]
            if call.name != "pick" and call.args and call.args[0] == culprit:
                return earlier
    return index - 1


def run_demo(
    simulator: Any, task: Any, seed: int, out_dir: Path | None, *, rng_seed: int | None = None
) -> dict[str, Any]:
    """Search the reference skeleton of ``task`` from ``seed``, replay it (recording ``out_dir/video.mp4``
    when ``out_dir`` is given) and return the ``result.json`` content."""
    from t2m_core.domain.goals import goal_satisfied_full

    started = time.perf_counter()
    reset = simulator.reset(task, seed=seed)
    search = search_skeleton(simulator, task.reference_skeleton, np.random.default_rng(seed if rng_seed is None else rng_seed))
    replay_reset = simulator.reset(task, seed=seed)
    steps: list[dict[str, Any]] = []
    video = None
    if out_dir is not None:
        from t2m_core.video import VideoWriter

        video = VideoWriter(out_dir / "video.mp4", fps=getattr(getattr(simulator, "options", None), "video_fps", 15))
        video.add(simulator.render())
        if hasattr(simulator, "stream_frames"):  # optional: backends without it give a still video
            simulator.stream_frames(video.add)
    failure = None
    try:
        for call, tries, action in zip(task.reference_skeleton, search.tries, [*search.actions, *[None] * len(task.reference_skeleton)], strict=False):
            if action is None:
                steps.append({"skill": str(call), "success": False, "tries": tries})
                continue
            outcome = simulator.execute(call.name, call.args, action)
            steps.append({"skill": str(call), "success": bool(outcome.success), "tries": tries, "failure": outcome.failure})
            if not outcome.success:
                failure = failure or f"replay of {call} failed: {outcome.failure}"
        final_state = simulator.geometric_state()
        reached = bool(goal_satisfied_full(task.goal, final_state, task.initial_state))
        if video is not None:
            for _ in range(8):  # about half a second of the final scene
                video.add(simulator.render())
    except BaseException:
        if video is not None:
            video._discard()
        raise
    finally:
        if hasattr(simulator, "stream_frames"):
            simulator.stream_frames(None)
    if video is not None:
        video.close()
    if not search.found:
        failure = failure or f"no parameters found for {task.reference_skeleton[len(search.actions)]}"
    elif not reached:
        failure = failure or "every skill succeeded but the goal does not hold"
    return {
        "success": reached and search.found,
        "task": task.id,
        "seed": seed,
        "accepted_seed": reset.accepted_seed,
        "replay_accepted_seed": replay_reset.accepted_seed,
        "steps": steps,
        "failure": failure,
        "failure_counts": search.failures,
        "executions": search.executions,
        "seconds": round(time.perf_counter() - started, 2),
    }


def demo(
    task_id: Annotated[str, typer.Option("--task", help="Task id, e.g. task0 (see `t2m tasks`).")],
    seed: Annotated[int, typer.Option("--seed", help="Reset seed.")] = 0,
    out: Annotated[Path, typer.Option("--out", help="Directory for video.mp4 and result.json.")] = Path("sim-demo"),
    sim: Annotated[str, typer.Option("--sim", help="Simulator plugin (see `t2m list-plugins`).")] = "mujoco",
    as_json: Annotated[bool, typer.Option("--json", help="Also print result.json on stdout.")] = False,
) -> None:
    """Execute a task's reference skeleton with sampled parameters and record a video."""
    from rich.console import Console

    from t2m_core.tasks import load_task

    console = Console(stderr=True)
    task = load_task(task_id)
    simulator = resolve_simulator(sim)
    out.mkdir(parents=True, exist_ok=True)
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


def register(app: typer.Typer) -> None:
    """Add ``t2m sim`` to the root app."""
    sim_app = typer.Typer(help="Simulator commands.", no_args_is_help=True)
    sim_app.command("demo")(demo)
    app.add_typer(sim_app, name="sim")
