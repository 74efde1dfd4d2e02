"""One Text2Motion episode, the Python API behind ``t2m run`` (docs/guide/run-records.md).

configuration → components → reset → scene parse → goal prediction → task planning → closed-loop
execution → ground-truth check → run directory. Every file of the run directory is written as the
episode goes (the transcript and the plan tree line by line), and ``result.json`` last, also when
the episode fails, is interrupted or stops on an error.
"""

from __future__ import annotations

import contextlib
import json
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from t2m_core.atomic_files import write_json_atomic, write_text_atomic
from t2m_core.components import build_component
from t2m_core.config.models import RunConfig
from t2m_core.metrics import EXECUTION_FAILURE, PLANNING_FAILURE, subgoal_completion

RUN_RECORD_FORMAT = "t2m-run/1"


@dataclass
class Timings:
    """Wall seconds per part of the episode."""

    language_model: float = 0.0
    feasibility: float = 0.0
    simulation: float = 0.0
    total: float = 0.0


@dataclass
class EpisodeResult:
    """What ``result.json`` holds (see docs/guide/run-records.md#resultjson)."""

    task: str
    seed: int
    instruction: str
    planner: str
    success: bool = False
    failure_type: str | None = None
    failure: str | None = None
    predicted_goal: list[list[str]] | None = None
    plan: list[str] = field(default_factory=list)
    executed: list[dict[str, Any]] = field(default_factory=list)
    goal_source: str = "task"
    subgoal_completion: float = 0.0
    llm_calls: int = 0
    stap_calls: int = 0
    accepted_seed: int | None = None
    interrupted: bool = False
    error: str | None = None
    timings: Timings = field(default_factory=Timings)

    def as_dict(self) -> dict[str, Any]:
        data = dict(self.__dict__)
        data["timings"] = {k: round(v, 3) for k, v in self.timings.__dict__.items()}
        return {"format": RUN_RECORD_FORMAT, **data}


class _Timed:
    """A component wrapper that adds the wall time of every method call to one timing bucket."""

    def __init__(self, component: Any, timings: Timings, bucket: str) -> None:
        self._component, self._timings, self._bucket = component, timings, bucket

    def __getattr__(self, name: str) -> Any:
        attribute = getattr(self._component, name)
        if not callable(attribute):
            return attribute

        def timed(*args: Any, **kwargs: Any) -> Any:
            started = time.perf_counter()
            try:
                return attribute(*args, **kwargs)
            finally:
                setattr(self._timings, self._bucket, getattr(self._timings, self._bucket) + time.perf_counter() - started)

        return timed


def run_episode(
    config: RunConfig,
    out: Path,
    *,
    instruction: str | None = None,
    on_event: Callable[[dict[str, Any]], None] | None = None,
) -> EpisodeResult:
    """Run one episode of ``config`` and record it in ``out``.

    Args:
        config: the resolved run configuration (task, seed, components).
        out: the run directory (created).
        instruction: replaces the task's instruction on the task's scene; success is then judged by
            the predicted goal (no ground truth).
        on_event: receives every plan-tree and execution record as it happens (a live view).
    """
    from t2m_core.closed_loop import execute_closed_loop
    from t2m_core.domain.goals import goal_satisfied_full
    from t2m_core.domain.observation import encode_observation
    from t2m_core.language.scene_description import describe_state
    from t2m_core.language.selection import create_language_model
    from t2m_core.language.session import LanguageSession
    from t2m_core.protocols import PlanningContext, SceneObservation
    from t2m_core.tasks import load_task

    started = time.perf_counter()
    out.mkdir(parents=True, exist_ok=True)
    write_text_atomic(out / "config.yaml", yaml.safe_dump(config.model_dump(mode="json"), sort_keys=False))
    task = load_task(config.task)
    text = instruction if instruction is not None else task.instruction
    planner_name = config.task_planner.name if config.task_planner else "none"
    result = EpisodeResult(task.id, config.seed, text, planner_name, goal_source="task" if instruction is None else "predicted")
    tree = (out / "plan_tree.jsonl").open("a", encoding="utf-8")

    def record(event: dict[str, Any]) -> None:
        if event.get("event") == "executed":
            result.executed.append({k: v for k, v in event.items() if k != "event"})
        tree.write(json.dumps(event) + "\n")
        tree.flush()
        if on_event is not None:
            on_event(event)

    simulator = build_component(config, "simulator")
    try:
        timings = result.timings
        skills = build_component(config, "skills")
        feasibility = _Timed(build_component(config, "feasibility_planner"), timings, "feasibility")
        planner = build_component(config, "task_planner")
        parser = build_component(config, "scene_parser")
        model = _Timed(
            create_language_model(config.language_model.name, config.language_model.options, transcript=out / "transcript.jsonl"),
            timings,
            "language_model",
        )
        reset = simulator.reset(task, seed=config.seed)
        result.accepted_seed = reset.accepted_seed
        state = parser.parse(SceneObservation(object_names=task.objects, ground_truth=reset.state))
        objects = state.object_names
        scene = describe_state(text, state, objects)
        session = LanguageSession(model, scene, seed=config.seed, example_plans=config.prompts.example_plans)
        goal_query = session.predict_goal()
        result.llm_calls += len(goal_query.attempts)
        record({"event": "goal", "goal": goal_query.goal.to_lists() if goal_query.goal else None,
                "attempts": [a.answer for a in goal_query.attempts]})
        if goal_query.goal is None:
            problems = [a.problem for a in goal_query.attempts if a.problem]
            result.failure_type = PLANNING_FAILURE
            if goal_query.no_goal is not None:  # the instruction has no goal in this scene: say why
                result.failure = f"no valid goal: {goal_query.no_goal.reason}"
            else:
                result.failure = "no valid goal prediction" + (f": {problems[-1]}" if problems else "")
            return result
        result.predicted_goal = goal_query.goal.to_lists()
        context = PlanningContext(text, goal_query.goal, session, skills, feasibility, objects, encode_observation(state, objects),
                                  simulator=_Timed(simulator, timings, "simulation"), on_event=record)
        with _video(out, simulator, config):  # the myopic baselines execute while they plan
            task_plan = planner.plan(context)
            result.llm_calls += task_plan.llm_calls
            result.stap_calls += task_plan.stap_calls
            result.plan = [str(c) for c in task_plan.skeleton]
            record({"event": "plan", "skeleton": result.plan, "found": task_plan.found, "failure": task_plan.failure,
                    "p_success": None if task_plan.plan is None else float(task_plan.plan.p_success)})
            executed_calls = list(task_plan.skeleton) if task_plan.executed else []
            if not task_plan.found:
                result.failure_type, result.failure = PLANNING_FAILURE, task_plan.failure
            elif not task_plan.executed:
                steps = execute_closed_loop(
                    _Timed(simulator, timings, "simulation"), feasibility, skills, task_plan.skeleton, objects,
                    on_step=lambda step: record({"event": "executed", **step.summary()}), closed_loop=config.run.closed_loop,
                    replan_start=config.run.replan_start, retry_below=config.run.retry_below, accepted=task_plan.plan,
                )
                result.stap_calls += len(steps.steps)
                executed_calls = [step.call for step in steps.steps if step.result.success]
                failed = next((s for s in steps.steps if not s.result.success), None)
                if failed is not None:
                    result.failure_type = EXECUTION_FAILURE
                    result.failure = f"{failed.call} failed: {failed.result.failure}"
        final = simulator.geometric_state()
        target = task.goal if instruction is None else goal_query.goal
        result.success = result.failure_type is None and bool(goal_satisfied_full(target, final, task.initial_state))
        if result.failure_type is None and not result.success:
            result.failure_type, result.failure = EXECUTION_FAILURE, "every skill succeeded but the goal does not hold"
        if instruction is None:
            result.subgoal_completion = subgoal_completion(task, executed_calls, result.success)
        return result
    except KeyboardInterrupt:
        result.interrupted = True
        result.failure = result.failure or "interrupted"
        raise
    except Exception as error:  # a part of the product broke: recorded, and `t2m eval` reruns the episode
        result.error = f"{type(error).__name__}: {error}"
        raise
    finally:
        simulator.close()
        tree.close()
        result.timings.total = time.perf_counter() - started
        write_json_atomic(out / "result.json", result.as_dict())


@contextlib.contextmanager
def _video(out: Path, simulator: Any, config: RunConfig):
    if not config.output.video or not hasattr(simulator, "stream_frames"):
        yield None
        return
    from t2m_core.video import VideoWriter

    with VideoWriter(out / "video.mp4", fps=getattr(getattr(simulator, "options", None), "video_fps", 15)) as video:
        video.add(simulator.render())
        simulator.stream_frames(video.add)
        try:
            yield video
        finally:
            simulator.stream_frames(None)
            for _ in range(8):
                video.add(simulator.render())
