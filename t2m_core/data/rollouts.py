"""Proposal data along rollouts of the task suite's reference skeletons
(docs/guide/skills.md#task-rollouts).

The data scenes of :mod:`t2m_core.data.scenes` place every object by the domain's sampler. A plan
does not leave the world like that: the second box a plan puts on the rack meets the first where
the first skill put it, and that is where the planner's proposals for the second fail. A task
rollout resets the simulator to a task of the suite at a seed far from the evaluation seeds, walks
the task's reference skeleton and, before every call of the chunk's skill, executes proposals
(:class:`~t2m_core.data.proposals.ProposalSampler`) from the exact snapshot of the reached state. It
then advances with the best-valued of the policy's noisy actions (a one-step stand-in for the
planner), retrying a few draws, and ends the rollout at a call it cannot advance. A chunk with a
``skeleton`` walks that sequence of its one task instead, another order a planner may choose
(docs/guide/skills.md#other-orders).

With the ``planned`` sampler a rollout goes where a run goes (docs/guide/skills.md#planned-rollouts):
before every call the feasibility planner (:data:`ROLLOUT_PLANNER`, a run's default, with its
default options) plans the rest of the skeleton from the reached state, closed loop as a run
re-plans; the chunk's skill executes that plan's action, then the action plus PolicyCEM's noise,
and the rollout advances with the planned action (the best-valued draws when it fails). Those are
the actions whose values the planner trusts most, so where its learned values are wrong they are
wrong there.

A rollout depends on every skill of its skeleton, so its chunks record the digest of the whole
library (:func:`~t2m_core.data.proposals.library_digest`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from functools import lru_cache
from typing import TYPE_CHECKING, Any

import numpy as np

from t2m_core.data.proposals import PROPOSAL_NOISE, ProposalSampler, library_digest, load_proposal_library
from t2m_core.domain.primitives import get_primitive
from t2m_core.domain.sampling import SamplingError
from t2m_core.domain.skills import SkillCall, parse_skeleton, validate_skill_call

if TYPE_CHECKING:
    from t2m_core.data.chunks import ChunkSpec, ChunkStats
    from t2m_core.tasks.model import Task

TASK_SEED_FLOOR = 10_000_000
"""Rollout scenes use base seeds from here up; evaluation episodes use seed index × 1 000 plus the
reset's rejections, far below."""
ADVANCE_ATTEMPTS = 4
"""Best-valued draws tried, each from the reached state's snapshot, before a rollout ends."""
NOT_ENUMERATED = -1
"""The ``symbolic_state`` column of a rollout row: its state is reached, not one of the enumerated
data states."""

ROLLOUT_PLANNER = "policy-cem"
"""The feasibility planner of ``planned`` rollouts (with its default options, as a run uses it)."""

RowMaker = Callable[..., dict[str, Any]]


TASKS_PREFIX = "tasks"
"""The scene source of rollouts: ``tasks`` (every shipped task whose skeleton calls the skill) or
``tasks:ID,ID`` (those of the named tasks)."""


def parse_rollout_tasks(scenes: str) -> tuple[str, ...] | None:
    """The task ids a rollout scene source names (``None``: every shipped task).

    Raises:
        ValueError: ``scenes`` is not ``tasks`` or ``tasks:ID,...``.
    """
    name, colon, ids = scenes.partition(":")
    if name != TASKS_PREFIX:
        raise ValueError(f"{scenes!r} is not a task-rollout scene source")
    if not colon:
        return None
    names = tuple(i.strip() for i in ids.split(",") if i.strip())
    if not names:
        raise ValueError(f"{scenes!r} names no task")
    return names


@lru_cache(maxsize=32)
def shipped_tasks(ids: tuple[str, ...] | None = None) -> tuple[Task, ...]:
    """The shipped tasks (all, or those with ``ids``), in id order.

    Raises:
        ValueError: an id that is not a shipped task.
    """
    from t2m_core.tasks import list_tasks

    tasks = list_tasks()
    if ids is not None:
        unknown = sorted(set(ids) - {task.id for task in tasks})
        if unknown:
            raise ValueError(f"no shipped task {', '.join(unknown)} (the tasks are {', '.join(t.id for t in tasks)})")
        tasks = tuple(task for task in tasks if task.id in ids)
    return tasks


def rollout_tasks(skill: str, ids: tuple[str, ...] | None = None) -> tuple[Task, ...]:
    """The shipped tasks (all, or those with ``ids``) whose reference skeleton calls ``skill``, in id order.

    Raises:
        ValueError: an id that is not a shipped task.
    """
    return tuple(task for task in shipped_tasks(ids) if any(call.name == skill for call in task.reference_skeleton))


def rollout_skeleton(task: Task, text: str) -> tuple[SkillCall, ...]:
    """``text`` (``"pick(hook), pull(blue_box, hook)"``) as skill calls of ``task``'s objects, argument
    types checked.

    Raises:
        SkillError: naming the entry and the problem.
    """
    calls = parse_skeleton(text, task.objects)
    for call in calls:
        validate_skill_call(call, task.objects)
    return calls


def rollout_library(spec: ChunkSpec, skills: tuple[str, ...]) -> dict[str, Any]:
    """The proposing skill library of a rollout chunk, checked against the digest it records."""
    source = spec.proposal
    assert source is not None  # ChunkSpec refuses task scenes without a proposal library
    return load_proposal_library(source.library, source.checkpoints, source.digest, lambda: library_digest(source.checkpoints, skills), "skill library")


def task_rollout_rows(
    spec: ChunkSpec, simulator: Any, rng: np.random.Generator, stats: ChunkStats, skills: tuple[str, ...], make_row: RowMaker
) -> Iterator[dict[str, Any] | None]:
    """The rows of one rollout (lazily: the caller stops when its chunk is full): ``None`` for a
    failed reset, else one row per proposal executed for a call of ``spec.skill``.

    Args:
        spec: the chunk (its skill, actions per scene and proposal library).
        simulator: a :class:`t2m_core.protocols.Simulator`.
        rng: the chunk's generator (the task, the scene seed and every draw come from it).
        stats: the chunk's counters (failed resets).
        skills: every learned skill, in the order :func:`library_digest` covers them.
        make_row: builds a row from ``(objects, arguments, symbolic_state, scene_seed, observation,
            action, next_observation, success, truncated, failure)``.
    """
    if spec.skeleton is None:
        tasks = rollout_tasks(spec.skill, parse_rollout_tasks(spec.scenes))
        task = tasks[int(rng.integers(len(tasks)))]
    else:
        (task,) = shipped_tasks(parse_rollout_tasks(spec.scenes))
    scene_seed = int(rng.integers(TASK_SEED_FLOOR, 2**31 - 1))
    started = time.perf_counter()
    try:
        reset = simulator.reset(task, seed=scene_seed)
    except SamplingError:
        stats.reset_failures += 1
        yield None
        return
    finally:
        stats.reset_seconds += time.perf_counter() - started
    stats.reset_rejections += reset.rejections
    library = rollout_library(spec, skills)
    objects = tuple(reset.state.object_names)
    skeleton = task.reference_skeleton if spec.skeleton is None else rollout_skeleton(task, spec.skeleton)
    last = max(i for i, call in enumerate(skeleton) if call.name == spec.skill)
    planner = rollout_planner() if spec.sampler == "planned" else None
    for index, call in enumerate(skeleton[: last + 1]):
        sampler = ProposalSampler(get_primitive(call.name), library[call.name])
        observation = simulator.observation()
        state = simulator.geometric_state()
        snapshot = simulator.get_state()
        encoded, policy_action = sampler.policy_action(observation, objects, call.args)
        planned = None if planner is None else planner.plan(observation, skeleton[index:], library, objects).actions[0].astype(np.float64)
        if call.name == spec.skill:
            for attempt in range(spec.actions_per_scene):
                if attempt:
                    simulator.set_state(snapshot)
                if planned is None:
                    action = sampler.draw(state, call.args, encoded, policy_action, rng)
                else:
                    action = planned if attempt == 0 else np.clip(planned + rng.normal(0.0, PROPOSAL_NOISE, planned.shape), -1.0, 1.0)
                result = simulator.execute(call.name, call.args, action)
                yield make_row(objects, call.args, NOT_ENUMERATED, reset.accepted_seed, observation, action, result.observation,
                               result.success, result.truncated, result.failure)
        if index == last or not advance(simulator, sampler, call, snapshot, encoded, policy_action, rng, planned):
            return


def rollout_planner_identity() -> dict[str, Any]:
    """What a ``planned`` dataset records of its planner: :data:`ROLLOUT_PLANNER` and its default
    options (a change of either makes other data, so a split made with one is never extended with
    the other)."""
    from t2m_core.registry import get_registry

    return {"name": ROLLOUT_PLANNER, "options": get_registry().get("feasibility_planner", ROLLOUT_PLANNER).options().model_dump(mode="json")}


@lru_cache(maxsize=1)
def rollout_planner() -> Any:
    """The :data:`ROLLOUT_PLANNER` feasibility planner, built once per process."""
    from t2m_core.registry import get_registry

    return get_registry().create("feasibility_planner", ROLLOUT_PLANNER)


def advance(simulator: Any, sampler: ProposalSampler, call: Any, snapshot: Any, encoded: np.ndarray, policy_action: np.ndarray,
             rng: np.random.Generator, planned: np.ndarray | None = None) -> bool:
    """Execute ``call`` from ``snapshot`` with the ``planned`` action ``(4,)`` when given, then with
    best-valued draws until one succeeds (at most :data:`ADVANCE_ATTEMPTS`); whether one did (the
    simulator is left in its outcome)."""
    if planned is not None:
        simulator.set_state(snapshot)
        if simulator.execute(call.name, call.args, planned).success:
            return True
    for _ in range(ADVANCE_ATTEMPTS):
        simulator.set_state(snapshot)
        if simulator.execute(call.name, call.args, sampler.optimum(encoded, policy_action, rng)).success:
            return True
    return False

