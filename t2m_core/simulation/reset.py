"""Reset to a task's initial state on any backend: sample, settle, verify, resample
(docs/guide/primitives.md#initial-state-sampling).

The domain sampler proposes a candidate (its own analytic rejections included); the backend drops
the objects from 5 cm, grips a sampled in-hand object without the grasp test, moves the arm to the
sampled random pose and settles for 1-60 ticks; the candidate is rejected, and the next seed tried,
when the pose is unreachable, settling needs all 60 ticks, an object is below the table or touches
the robot base, a child no longer sits above its non-table parent, or an initial proposition is false.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from typing import Any

from t2m_core.domain.geometry import is_above, object_geometry
from t2m_core.domain.objects import ObjectKind, object_spec
from t2m_core.domain.observation import encode_observation
from t2m_core.domain.predicates import holds_all
from t2m_core.domain.propositions import Proposition, canonical_order
from t2m_core.domain.primitives import MotionKind, MotionStep
from t2m_core.domain.sampling import SampledScene, SamplingError, sample_initial_state
from t2m_core.protocols import ResetResult
from t2m_core.simulation.backend import PhysicsBackend
from t2m_core.simulation.motion import MotionExecutor

RESET_SETTLE_MAX_TICKS = 60
"""Settle at most 1 s; needing all of it rejects the seed."""
RESET_HOLD_TICKS = 10
"""Ticks that close the fingers on an object put in hand by the sampler (the non-realistic grasp)."""


def reset_to_task(
    backend: PhysicsBackend, motions: MotionExecutor, task: Any, seed: int, max_attempts: int
) -> tuple[ResetResult, dict[str, Any]]:
    """Sample, settle and verify ``task``'s initial state from ``seed``, trying the next seeds on a
    physical rejection. The backend must hold ``task``'s objects.

    Returns:
        the reset result, and ``{"sampler_rejections", "physics_rejections", "reasons"}``.

    Raises:
        SamplingError: no candidate seed was accepted within ``max_attempts``.
    """
    names = tuple(task.objects)
    propositions = canonical_order(task.initial_state)
    candidate = int(seed)
    sampler_rejections = 0
    reasons: Counter[str] = Counter()
    for _ in range(max_attempts):
        sampled = sample_initial_state(names, propositions, candidate)
        sampler_rejections += sampled.rejections
        reason = realise(backend, motions, sampled, propositions)
        if reason is None:
            stats = {
                "sampler_rejections": sampler_rejections,
                "physics_rejections": sum(reasons.values()),
                "reasons": dict(reasons),
            }
            backend.ticks = 0
            backend.canonicalize()
            state = backend.geometric_state()
            result = ResetResult(
                state=state,
                observation=encode_observation(state, names),
                accepted_seed=sampled.accepted_seed,
                rejections=sampler_rejections + sum(reasons.values()),
            )
            return result, stats
        reasons[reason] += 1
        candidate = sampled.accepted_seed + 1
    raise SamplingError(
        f"no initial state of {getattr(task, 'id', names)} survived physics in {max_attempts} "
        f"candidates from seed {seed}; rejections: {dict(reasons)}",
        "raise max_reset_attempts, or check the task's initial state",
    )


def realise(backend: PhysicsBackend, motions: MotionExecutor, sampled: SampledScene, propositions: Sequence[Proposition]) -> str | None:
    """Load a sampled candidate into physics; ``None`` if it survives, else the rejection reason."""
    backend.reset_robot()
    drop = sampled.drop_state
    backend.place_objects({name: drop.objects[name] for name in backend.free_names})
    held = drop.held
    if held is not None:
        # Non-realistic grasp: weld first, then close the fingers onto the object.
        backend.attach(held)
        backend.set_gripper(0.0)
        backend.tick(RESET_HOLD_TICKS)
        backend.set_gripper(backend.finger_q())
        if backend.held_touches_robot(held):
            return "held_object_touches_robot"
    move = MotionStep(MotionKind.MOVE, "random_pose", sampled.robot_pose.position, sampled.robot_pose.yaw)
    motions.begin_primitive()
    if motions.run(move).failure is not None:
        return "robot_pose_unreachable"
    if motions.settle(RESET_SETTLE_MAX_TICKS / 60.0) >= RESET_SETTLE_MAX_TICKS:
        return "did_not_settle"
    state = backend.geometric_state()
    for name in backend.free_names:
        if state.objects[name].position[2] < 0.0:
            return "below_table"
    if backend.objects_touch_base():
        return "touches_robot_base"
    for prop in propositions:
        if prop.predicate == "on" and object_spec(prop.args[1]).kind is not ObjectKind.TABLE:
            child, parent = prop.args
            if not is_above(object_geometry(child, state.objects[child]), object_geometry(parent, state.objects[parent])):
                return "fell_off_support"
    if not holds_all(propositions, state):
        return "propositions_failed"
    return None
