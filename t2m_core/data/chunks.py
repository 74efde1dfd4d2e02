"""One chunk of skill data: a pure function of (skill, split, chunk index, size, base seed) and the
simulator's options (docs/guide/skills.md#data-generation).

Every random draw of a chunk comes from one NumPy generator seeded with those numbers, and every
simulator reset starts from a cleared physics state, so a chunk's transitions do not depend on which
process runs it or what it ran before: a killed run can redo a chunk, and a cluster can run chunks
anywhere.
"""

from __future__ import annotations

import math
import time
from collections import Counter
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from t2m_core.data.evaluation_scenes import evaluation_task
from t2m_core.data.records import (
    INVALID_GROUNDING,
    MAX_ARGUMENTS,
    Transitions,
    empty_transitions,
    failure_code,
    name_indices,
)
from t2m_core.data.rollouts import (
    parse_rollout_tasks,
    rollout_planner_identity,
    rollout_skeleton,
    rollout_tasks,
    shipped_tasks,
    task_rollout_rows,
)
from t2m_core.data.scenes import DATA_SKILLS, DataTask, draw_data_task
from t2m_core.domain.geometry import quat_multiply, rotate, yaw_to_quat
from t2m_core.domain.observation import MAX_OBJECTS, argument_first_order, encode_observation
from t2m_core.domain.primitives import Primitive, get_primitive
from t2m_core.domain.sampling import SamplingError, sample_initial_state
from t2m_core.domain.skills import SkillError
from t2m_core.domain.state import GeometricState, ObjectPose
from t2m_core.errors import T2MError

SPLITS: tuple[str, ...] = ("train", "validation", "invalid")
"""Dataset splits: simulated valid groundings for training and model selection; symbolically
invalid groundings, not simulated, for OOD calibration."""
MIN_SUCCESS_FRACTION = 0.4
"""Balancing: at least this share of a chunk's transitions are successes."""
MAX_DRAWS_PER_TRANSITION = 200
"""A chunk that needs more draws than this per kept transition gives up (a broken simulator)."""
SAMPLERS: dict[str, str] = {
    "screened": "screened_exploration_action",
    "heuristic": "exploration_action",
    "uniform": "uniform",
    "proposal": "proposal",
    "planned": "planned",
    "obstructed": "obstructed_exploration_action",
}
"""Action samplers of data generation -> :class:`Primitive` method (``uniform``: U[-1, 1]^4;
``proposal``: a skill library's proposals, :mod:`t2m_core.data.proposals`; ``planned``: the
feasibility planner's actions along task rollouts, :mod:`t2m_core.data.rollouts`; ``obstructed``: the
screened sampler, half of whose draws sweep into a bystander where one can, Pull and Push only)."""
SKILL_SAMPLERS: dict[str, tuple[str, ...]] = {"obstructed": ("pull", "push")}
"""Samplers that only some skills have (the others: every skill)."""
LIBRARY_SAMPLERS: tuple[str, ...] = ("proposal", "planned")
"""Samplers that propose with a skill library (they need one, and only they may roll out tasks)."""
UNBALANCED_SAMPLERS: tuple[str, ...] = ("planned",)
"""Samplers whose chunks keep every transition (no balancing): a planned rollout is there for the
planner's failures, and a chunk that dropped failures once it held its share would keep only the
successes of its later scenes (docs/guide/skills.md#planned-rollouts)."""
SCENES: tuple[str, ...] = ("data", "tasks", "evaluation")
"""Where simulated transitions start: ``data``, the enumerated symbolic states with distractors
(:mod:`t2m_core.data.scenes`); ``tasks``, states reached along rollouts of the task suite's
reference skeletons (:mod:`t2m_core.data.rollouts`, proposal or planned sampler), or ``tasks:ID,ID``
along those of the named tasks only; ``evaluation``, the single-skill evaluation scenes
(:mod:`t2m_core.data.evaluation_scenes`), drawn from the chunk's own stream: the scenes a policy's
success is reported in, not the report's or the selection's instances."""


def rollout_scenes(scenes: str) -> bool:
    """Whether the scene source ``scenes`` starts transitions along task rollouts (``tasks`` or ``tasks:ID,ID``)."""
    return scenes.partition(":")[0] == "tasks"


class DataGenerationError(T2MError):
    """A chunk that cannot be generated (unknown skill or split, a simulator that never succeeds)."""


@dataclass(frozen=True)
class ProposalSource:
    """The skill library a ``proposal`` sampler proposes with (see :class:`ChunkSpec`)."""

    library: str
    checkpoints: str
    digest: str

    def identity(self) -> dict[str, str]:
        """What a shard and a manifest record: the library and its checkpoint's digest, not where
        the checkpoint lies on this machine."""
        return {"library": self.library, "digest": self.digest}


@dataclass(frozen=True)
class ChunkSpec:
    """Everything a chunk's content depends on, besides the simulator and its options.

    Attributes:
        skill: ``pick``, ``place``, ``pull`` or ``push``.
        split: ``train``, ``validation`` or ``invalid``.
        index: the chunk's position in its split (0, 1, ...).
        size: transitions it holds.
        base_seed: the dataset's seed; splits and chunks draw independent streams from it.
        sampler: action sampler of simulated splits (a key of :data:`SAMPLERS`).
        actions_per_scene: actions executed from each reset scene of a simulated split, each from
            the same exact snapshot: a reset costs 2-4 executions, so more than one action per scene
            makes data several times cheaper (docs/guide/skills.md#actions-per-scene).
        proposal: for the ``proposal`` and ``planned`` samplers, the skill library it proposes with: ``library``
            (plugin name), ``checkpoints`` (directory, one sub-directory per skill) and ``digest``
            (:func:`~t2m_core.data.proposals.checkpoint_digest` of this skill's checkpoint, which
            the chunk's content depends on; the directory does not; with task scenes,
            :func:`~t2m_core.data.proposals.library_digest` of every skill's).
        scenes: where simulated transitions start (a name of :data:`SCENES`).
        skeleton: with task scenes of one task (``tasks:ID``), the skill sequence the rollouts walk
            instead of its reference skeleton, canonical text (``"pick(hook), pull(blue_box,
            hook)"``): another order a planner may choose (docs/guide/skills.md#other-orders).
    """

    skill: str
    split: str
    index: int
    size: int
    base_seed: int = 0
    sampler: str = "screened"
    actions_per_scene: int = 1
    proposal: ProposalSource | None = None
    scenes: str = "data"
    skeleton: str | None = None

    def __post_init__(self) -> None:
        if self.skill not in DATA_SKILLS:
            raise DataGenerationError(f"unknown skill {self.skill!r}", f"use one of: {', '.join(DATA_SKILLS)}")
        if self.split not in SPLITS:
            raise DataGenerationError(f"unknown split {self.split!r}", f"use one of: {', '.join(SPLITS)}")
        if self.sampler not in SAMPLERS:
            raise DataGenerationError(f"unknown action sampler {self.sampler!r}", f"use one of: {', '.join(SAMPLERS)}")
        if self.skill not in SKILL_SAMPLERS.get(self.sampler, DATA_SKILLS):
            raise DataGenerationError(f"the {self.sampler} sampler has no {self.skill} draws",
                                      f"use it with {' or '.join(SKILL_SAMPLERS[self.sampler])}, or another --sampler")
        if (self.sampler in LIBRARY_SAMPLERS) != (self.proposal is not None) and self.simulated:
            raise DataGenerationError("the proposal and planned samplers, and only they, need a proposal skill library",
                                      "give --proposal-checkpoints with --sampler proposal or planned")
        if self.scenes.partition(":")[0] not in SCENES:
            raise DataGenerationError(f"unknown scene source {self.scenes!r}", f"use one of: {', '.join(SCENES)}, or tasks:ID,ID (e.g. tasks:task0,task2)")
        if self.scenes == "evaluation" and (self.skeleton is not None or not self.simulated):
            raise DataGenerationError("evaluation scenes hold simulated transitions of one call, without a skeleton",
                                      "use --scenes evaluation with the train or validation split and no --skeleton")
        if self.skeleton is not None:
            self._check_skeleton()
        elif self.rollouts:
            self._check_rollout_tasks()
        if self.rollouts and (self.sampler not in LIBRARY_SAMPLERS or not self.simulated):
            raise DataGenerationError("task-rollout scenes need the proposal or planned sampler (it advances along the skeletons) and a simulated split",
                                      "add --sampler proposal, or drop --scenes tasks")
        if self.sampler == "planned" and not self.rollouts and self.simulated:
            raise DataGenerationError("the planned sampler plans along task rollouts, not in data scenes", "add --scenes tasks or tasks:ID")
        if self.size < 1 or self.index < 0 or self.base_seed < 0 or self.actions_per_scene < 1:
            raise DataGenerationError(f"chunk size and actions per scene must be >= 1 and index, seed >= 0; got {self}")

    def _check_rollout_tasks(self) -> None:
        try:
            tasks = rollout_tasks(self.skill, parse_rollout_tasks(self.scenes))
        except ValueError as error:
            raise DataGenerationError(f"unknown scene source {self.scenes!r}: {error}", "use data, tasks, or tasks:ID,ID (e.g. tasks:task0,task2)") from None
        if not tasks:
            raise DataGenerationError(f"no task of {self.scenes!r} calls {self.skill} in its reference skeleton", "name tasks whose plans use the skill")

    def _check_skeleton(self) -> None:
        try:
            ids = parse_rollout_tasks(self.scenes) if self.rollouts else None
            task = shipped_tasks(ids)[0] if ids is not None and len(ids) == 1 else None
        except ValueError as error:
            raise DataGenerationError(f"unknown scene source {self.scenes!r}: {error}", "use tasks:ID with a shipped task id") from None
        if task is None:
            raise DataGenerationError(f"a rollout skeleton needs the scenes of one task, not {self.scenes!r}", "add --scenes tasks:ID (e.g. tasks:task3)")
        try:
            calls = rollout_skeleton(task, self.skeleton)
        except SkillError as error:
            raise DataGenerationError(f"rollout skeleton for {task.id}: {error.message}", error.hint) from None
        if self.skill not in [call.name for call in calls]:
            raise DataGenerationError(f"the rollout skeleton {self.skeleton!r} never calls {self.skill}", f"give a skeleton that calls {self.skill}")

    @property
    def filename(self) -> str:
        """``chunk-00003.safetensors``."""
        return f"chunk-{self.index:05d}.safetensors"

    @property
    def rollouts(self) -> bool:
        """Whether transitions start along task rollouts (:func:`rollout_scenes`)."""
        return rollout_scenes(self.scenes)

    @property
    def simulated(self) -> bool:
        """Whether the chunk runs the simulator (the invalid split does not)."""
        return self.split != "invalid"

    def rng(self) -> np.random.Generator:
        """The chunk's generator: independent streams per (base seed, skill, split, index)."""
        words = [self.base_seed, DATA_SKILLS.index(self.skill), SPLITS.index(self.split), self.index]
        return np.random.default_rng(np.random.SeedSequence(words))

    def header(self) -> dict[str, Any]:
        """The fields that identify the chunk, as its shard header stores them (``actions_per_scene``
        only when above 1: a shard without it was made with one action per scene)."""
        header: dict[str, Any] = {
            "skill": self.skill,
            "split": self.split,
            "index": self.index,
            "size": self.size,
            "base_seed": self.base_seed,
            "sampler": self.sampler if self.simulated else "uniform",
        }
        if self.simulated and self.actions_per_scene > 1:
            header["actions_per_scene"] = self.actions_per_scene
        if self.simulated and self.proposal is not None:
            header["proposal"] = self.proposal.identity()
        if self.scenes != "data":
            header["scenes"] = self.scenes
        if self.skeleton is not None:
            header["skeleton"] = self.skeleton
        if self.simulated and self.sampler == "planned":
            header["planner"] = rollout_planner_identity()
        return header


@dataclass
class ChunkStats:
    """What it cost to produce a chunk.

    Attributes:
        draws: executed actions and failed resets, including discarded failures.
        discarded_failures: failures dropped by the balancing rule.
        reset_failures: draws whose scene could not be sampled or settled.
        reset_rejections: candidate seeds rejected inside accepted resets.
        seconds: wall time, of which ``reset_seconds`` went into resets.
    """

    draws: int = 0
    discarded_failures: int = 0
    reset_failures: int = 0
    reset_rejections: int = 0
    seconds: float = 0.0
    reset_seconds: float = 0.0
    failures: Counter[str] = field(default_factory=Counter)

    def as_dict(self) -> dict[str, Any]:
        """The deterministic counts, JSON-ready (the timings vary from run to run, so shards leave
        them out and stay byte-identical)."""
        return {
            "draws": self.draws,
            "discarded_failures": self.discarded_failures,
            "reset_failures": self.reset_failures,
            "reset_rejections": self.reset_rejections,
            "failures": dict(sorted(self.failures.items())),
        }


def generate_chunk(spec: ChunkSpec, simulator: Any = None) -> tuple[Transitions, ChunkStats]:
    """Generate one chunk.

    Simulated splits reset ``simulator`` to a drawn (state, call) scene, then draw an action with the
    spec's sampler and execute it, ``actions_per_scene`` times from the same snapshot, keeping every
    success and failures only while they are under 60 % of the chunk (the balancing rule; the
    samplers of :data:`UNBALANCED_SAMPLERS` keep every failure). The invalid split encodes analytically sampled scenes
    of symbolically invalid calls with uniform actions, reward 0 and ``next_observation =
    observation``.

    Args:
        spec: the chunk.
        simulator: a :class:`t2m_core.protocols.Simulator`; unused for the invalid split.

    Raises:
        DataGenerationError: no simulator for a simulated split, or too many draws per transition.
    """
    if spec.simulated and simulator is None:
        raise DataGenerationError(f"the {spec.split} split needs a simulator")
    rng = spec.rng()
    stats = ChunkStats()
    started = time.perf_counter()
    max_failures = spec.size if spec.sampler in UNBALANCED_SAMPLERS else spec.size - math.ceil(MIN_SUCCESS_FRACTION * spec.size)
    rows: list[dict[str, Any]] = []
    kept_failures = 0
    while len(rows) < spec.size:
        if spec.rollouts:
            scene_rows = task_rollout_rows(spec, simulator, rng, stats, DATA_SKILLS, _row)
        else:
            task = evaluation_task(spec.skill, rng) if spec.scenes == "evaluation" else draw_data_task(spec.skill, spec.simulated, rng)
            scene_seed = int(rng.integers(2**31 - 1))
            scene_rows = _simulated_rows(spec, simulator, task, scene_seed, rng, stats) if spec.simulated else iter([_invalid_row(task, scene_seed, rng)])
        for row in scene_rows:
            stats.draws += 1
            if stats.draws > MAX_DRAWS_PER_TRANSITION * spec.size:
                raise DataGenerationError(
                    f"{spec.skill} {spec.split} chunk {spec.index}: {stats.draws} draws for {len(rows)} transitions "
                    f"({stats.reset_failures} failed resets, failures {dict(stats.failures)})",
                    "check the simulator with `t2m sim demo`; a skill that never succeeds cannot be balanced",
                )
            if row is None:
                continue
            if row["reward"] < 0.5:
                stats.failures[row["failure_name"]] += 1
                if spec.simulated and kept_failures >= max_failures:
                    stats.discarded_failures += 1
                    continue
                kept_failures += 1
            rows.append(row)
            if len(rows) == spec.size:
                break
    stats.seconds = time.perf_counter() - started
    return _stack(rows), stats


def _action_sampler(name: str, primitive: Primitive) -> Callable[[GeometricState, tuple[str, ...], np.random.Generator], np.ndarray]:
    if name == "uniform":
        return lambda state, arguments, rng: rng.uniform(-1.0, 1.0, primitive.action_dim)
    return getattr(primitive, SAMPLERS[name])


def _scene_sampler(spec: ChunkSpec, task: DataTask, state: GeometricState, observation: np.ndarray) -> Callable[[np.random.Generator], np.ndarray]:
    """The spec's action sampler bound to one reset scene (the proposal sampler computes the
    policy's action once per scene)."""
    primitive = get_primitive(spec.skill)
    if spec.proposal is None:
        sampler = _action_sampler(spec.sampler, primitive)
        return lambda rng: sampler(state, task.call.args, rng)
    from t2m_core.data.proposals import load_proposal_sampler

    proposals = load_proposal_sampler(primitive, spec.proposal.library, spec.proposal.checkpoints, spec.proposal.digest)
    encoded, policy_action = proposals.policy_action(observation, task.objects, task.call.args)
    return lambda rng: proposals.draw(state, task.call.args, encoded, policy_action, rng)


def _simulated_rows(
    spec: ChunkSpec, simulator: Any, task: DataTask, scene_seed: int, rng: np.random.Generator, stats: ChunkStats
) -> Iterator[dict[str, Any] | None]:
    """The rows of one scene: ``None`` for a failed reset, else one row per action, each executed
    from the reset's exact snapshot (drawn lazily: the caller stops when its chunk is full)."""
    reset_started = time.perf_counter()
    try:
        reset = simulator.reset(task, seed=scene_seed)
    except SamplingError:
        reset = None
        stats.reset_failures += 1
    finally:
        stats.reset_seconds += time.perf_counter() - reset_started
    if reset is None:
        yield None
        return
    stats.reset_rejections += reset.rejections
    sampler = _scene_sampler(spec, task, reset.state, reset.observation)
    snapshot = simulator.get_state() if spec.actions_per_scene > 1 else None
    for attempt in range(spec.actions_per_scene):
        if attempt:
            simulator.set_state(snapshot)
        action = sampler(rng)
        result = simulator.execute(spec.skill, task.call.args, action)
        yield _row(task.objects, task.call.args, task.symbolic_state, reset.accepted_seed, reset.observation, action, result.observation,
                   result.success, result.truncated, result.failure)


def _invalid_row(task: DataTask, scene_seed: int, rng: np.random.Generator) -> dict[str, Any] | None:
    """An invalid-split row: the scene sampled analytically (no physics), the robot moved to the
    sampler's random pose (carrying a held object along), a uniform action."""
    try:
        sampled = sample_initial_state(task.objects, task.initial_state, scene_seed)
    except SamplingError:
        return None
    state = _at_robot_pose(sampled.state, sampled.robot_pose.position, sampled.robot_pose.yaw)
    observation = encode_observation(state, task.objects)
    action = rng.uniform(-1.0, 1.0, 4)
    return _row(task.objects, task.call.args, task.symbolic_state, sampled.accepted_seed, observation, action, observation, False, False,
                INVALID_GROUNDING)


def _at_robot_pose(state: GeometricState, ee_position: np.ndarray, ee_yaw: float) -> GeometricState:
    """``state`` with the end effector moved from its (home) pose to ``ee_position`` at ``ee_yaw``
    (radians, relative to home), the held object moving rigidly with it."""
    turn = yaw_to_quat(ee_yaw)
    objects = dict(state.objects)
    if state.held is not None:
        pose = objects[state.held]
        offset = rotate(turn, pose.position - state.ee_position)
        objects[state.held] = ObjectPose(ee_position + offset, quat_multiply(turn, pose.quaternion))
    return GeometricState(objects, np.asarray(ee_position, dtype=np.float64), quat_multiply(turn, state.ee_quaternion), state.held)


def _row(
    objects: tuple[str, ...],
    arguments: tuple[str, ...],
    symbolic_state: int,
    scene_seed: int,
    observation: np.ndarray,
    action: np.ndarray,
    next_observation: np.ndarray,
    success: bool,
    truncated: bool,
    failure: str | None,
) -> dict[str, Any]:
    order = argument_first_order(objects, arguments)
    return {
        "observation": np.asarray(observation, dtype=np.float32),
        "action": np.asarray(action, dtype=np.float32),
        "reward": np.float32(1.0 if success else 0.0),
        "next_observation": np.asarray(next_observation, dtype=np.float32),
        "terminated": not truncated,
        "truncated": bool(truncated),
        "failure": failure_code(failure),
        "failure_name": failure,
        "arguments": name_indices(arguments, MAX_ARGUMENTS),
        "present": name_indices(objects, MAX_OBJECTS),
        "row_order": order.order.astype(np.int8),
        "shuffle_range": np.array([order.shuffle_start, order.shuffle_stop], dtype=np.int8),
        "symbolic_state": symbolic_state,
        "scene_seed": scene_seed,
    }


def _stack(rows: list[dict[str, Any]]) -> Transitions:
    template = empty_transitions()
    if not rows:
        return template
    columns = {}
    for name, empty in template.columns().items():
        columns[name] = np.asarray([row[name] for row in rows], dtype=empty.dtype).reshape(len(rows), *empty.shape[1:])
    return Transitions(**columns)
