"""The contract between the TableEnv domain and a physics backend for executing primitives.

The domain decides everything geometric: action ranges, the waypoints of every sub-motion, which
bodies a guarded motion may not touch, which objects must not be disturbed, the mid-sequence checks
and the post-conditions (docs/guide/primitives.md#executing-a-primitive-the-backend-contract). A backend only executes :class:`MotionStep` s in order and
answers queries. One primitive execution, as a backend runs it::

    primitive = PRIMITIVES[name]
    start = backend.geometric_state()
    reason = primitive.precheck(start, arguments, action)          # e.g. "not_in_workspace"
    for step in () if reason else primitive.motion(start, arguments, action):
        reason = backend.run(step)                                  # "collision", "unreachable", "grasp_failed"
        reason = reason or first_disturbed(start, backend.geometric_state(), step.disturbance_objects)
        reason = reason or (step.check and step.check(StepContext(start, backend.geometric_state(), ...)))
        if reason: break
    outcome = Outcome.failed(reason) if reason else primitive.outcome(start, backend.geometric_state(), arguments)

Failure reasons form the small vocabulary :data:`FAILURES`; each is either a control failure
(``truncated = True``) or a post-condition failure (``truncated = False``).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from t2m_core.domain.constants import MAX_LIFT_HEIGHT
from t2m_core.domain.geometry import did_move
from t2m_core.domain.objects import ObjectKind, object_spec
from t2m_core.domain.state import GeometricState

SETTLE_TIMEOUT_S = 3.0
"""Longest "wait until stable" at the end of a primitive, seconds."""

EXPLORATION_HEURISTIC_PROBABILITY = 0.9
"""Exploration sampler: probability of the noisy heuristic action instead of a uniform one."""

EXPLORATION_NOISE_STD = 0.05
"""Exploration sampler: per-dimension Gaussian noise on the heuristic action, normalised units."""


# --------------------------------------------------------------------------------------------------
# Failure vocabulary
# --------------------------------------------------------------------------------------------------

FAILURES: dict[str, tuple[bool, str]] = {
    # control failures (truncated): the motion was aborted
    "not_in_workspace": (True, "the object (Pick) or the pre-pose (Place) is outside the workspace"),
    "not_held": (True, "Place/Pull/Push need their object (Place) or the hook (Pull, Push) in hand"),
    "target_behind_robot": (True, "Pull/Push target has x < 0: the polar frame is undefined"),
    "unreachable": (True, "the backend's controller hit a joint limit or singularity (reported by the backend)"),
    "collision": (True, "a finger pad or the held object touched a forbidden body during a guarded motion"),
    "disturbed": (True, "a non-argument object moved >= 0.05 m or >= 5 deg since the primitive started"),
    "grasp_failed": (True, "the gripper closed on nothing or the pad contacts were invalid"),
    "too_high": (True, "Place: the held object was farther than 0.05 m from the target before release"),
    "below_table": (True, "the object fell off the table (centre z < 0)"),
    "tipped_over": (True, "Pull/Push: the target was not upright after the reach or the sweep"),
    "not_pushed": (True, "Push: the target's distance from the base did not grow by more than d_Push"),
    "not_under": (True, "Push: the target did not end under the rack"),
    # post-condition failures (not truncated): the motion ran, the result is wrong
    "not_upright": (False, "Place/Pull: the object is not upright at the end"),
    "not_on_target": (False, "Place: the object is not above the target at the end"),
    "not_pulled": (False, "Pull: the target's distance from the base did not shrink by more than d_Pull"),
    "outside_workspace": (False, "Pull: the target did not end inside the workspace"),
}
"""Failure reason -> (truncated, meaning). Backends add no reasons of their own beyond these."""


def is_truncated(failure: str) -> bool:
    """Whether ``failure`` is a control failure (``truncated``); raises ``KeyError`` for unknown reasons."""
    try:
        return FAILURES[failure][0]
    except KeyError:
        raise KeyError(f"unknown failure reason {failure!r}; known reasons: {', '.join(FAILURES)}") from None


@dataclass(frozen=True)
class Outcome:
    """Result of a primitive: success (reward 1) or a failure reason from :data:`FAILURES`."""

    success: bool
    failure: str | None = None

    def __post_init__(self) -> None:
        if self.success != (self.failure is None):
            raise ValueError("an Outcome has a failure reason exactly when it is not a success")
        if self.failure is not None:
            is_truncated(self.failure)

    @property
    def truncated(self) -> bool:
        """A control failure ended the primitive."""
        return self.failure is not None and is_truncated(self.failure)

    @classmethod
    def ok(cls) -> Outcome:
        return cls(True, None)

    @classmethod
    def failed(cls, failure: str) -> Outcome:
        return cls(False, failure)


# --------------------------------------------------------------------------------------------------
# Motion steps
# --------------------------------------------------------------------------------------------------


class MotionKind(str, Enum):
    """What a backend does for one :class:`MotionStep`."""

    MOVE = "move"  # free-space move of the EE to a pose at lift height
    DESCEND = "descend"  # straight, contact-guarded move down (or across) to a pose
    SWEEP = "sweep"  # compliant straight move of a held tool (soft gains)
    LIFT = "lift"  # straight move up to a pose at lift height
    GRASP = "grasp"  # close the gripper, validate the grasp (docs/guide/world.md#grasping), weld the object
    RELEASE = "release"  # open the gripper and drop the weld
    SETTLE = "settle"  # step until no object moves, at most ``timeout_s``


@dataclass(frozen=True)
class StepContext:
    """What a mid-sequence check sees after its step.

    Attributes:
        start_state: the geometric state when the primitive started.
        state: the geometric state now.
        arguments: the primitive's object arguments.
        distance: closest distance in metres between two named bodies, answered by the backend
            (negative when penetrating).
    """

    start_state: GeometricState
    state: GeometricState
    arguments: tuple[str, ...]
    distance: Callable[[str, str], float]


StepCheck = Callable[[StepContext], "str | None"]
"""A domain test run after a step: a failure reason from :data:`FAILURES`, or ``None`` to go on."""


@dataclass(frozen=True)
class MotionStep:
    """One sub-motion of a primitive, in world coordinates.

    Attributes:
        kind: what to do.
        label: short name for logs and videos (``"pre_pose"``, ``"grasp_pose"``...).
        ee_position: ``(3,) float64`` target of the EE operational point in metres, or ``None`` for
            gripper/settle steps.
        ee_yaw: target gripper yaw in radians, relative to the home orientation: the commanded
            relative orientation is ``Rz(ee_yaw)`` (top-down), executed as ``Rz(ee_yaw)·q_home``
            (docs/guide/world.md#the-robot). ``None`` keeps the current orientation.
        contact_objects: bodies that the finger pads and the held object must not touch during this
            step (checked every 10 ticks); a contact fails with ``"collision"``.
        disturbance_objects: objects tested with the 0.05 m / 5° disturbance rule after the step,
            against their poses when the primitive started (see :func:`first_disturbed`).
        soft: use the compliant gains of tool sweeps.
        grasp_object: the object to grasp (``GRASP`` only).
        timeout_s: longest duration of a ``SETTLE`` step, seconds.
        check: domain test after the step (and after the disturbance test).
    """

    kind: MotionKind
    label: str
    ee_position: np.ndarray | None = None
    ee_yaw: float | None = None
    contact_objects: tuple[str, ...] = ()
    disturbance_objects: tuple[str, ...] = ()
    soft: bool = False
    grasp_object: str | None = None
    timeout_s: float | None = None
    check: StepCheck | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        if self.ee_position is not None:
            object.__setattr__(self, "ee_position", np.asarray(self.ee_position, dtype=np.float64).reshape(3))
        if self.ee_yaw is not None:
            object.__setattr__(self, "ee_yaw", float(self.ee_yaw))
        moves = (MotionKind.MOVE, MotionKind.DESCEND, MotionKind.SWEEP, MotionKind.LIFT)
        if (self.kind in moves) != (self.ee_position is not None):
            raise ValueError(f"{self.kind.value} step {self.label!r}: an EE target is given exactly for motions")
        if self.kind is MotionKind.GRASP and self.grasp_object is None:
            raise ValueError(f"grasp step {self.label!r} needs grasp_object")


# --------------------------------------------------------------------------------------------------
# Primitives
# --------------------------------------------------------------------------------------------------


class Primitive(ABC):
    """One motion primitive of TableEnv.

    Subclasses set :attr:`name`, :attr:`argument_kinds`, :attr:`action_low` and :attr:`action_high`
    and implement :meth:`motion`; they override :meth:`precheck`, :meth:`outcome` and
    :meth:`heuristic_physical` where the primitive has them. Actions are normalised ``(4,)`` arrays
    in ``[-1, 1]``; :meth:`to_physical` maps them linearly to the physical ranges
    (docs/guide/primitives.md#actions).
    """

    name: str
    argument_kinds: tuple[frozenset[ObjectKind], ...]
    """Allowed object kinds per argument position."""
    action_low: np.ndarray
    """``(4,) float64`` physical lower bounds."""
    action_high: np.ndarray
    """``(4,) float64`` physical upper bounds."""

    action_dim: int = 4

    # --- action mapping ---------------------------------------------------------------------------

    def to_physical(self, action: np.ndarray) -> np.ndarray:
        """``(..., 4)`` normalised -> physical: ``low + (a + 1)/2 · (high − low)``."""
        action = np.asarray(action, dtype=np.float64)
        return self.action_low + (action + 1.0) / 2.0 * (self.action_high - self.action_low)

    def to_normalized(self, physical: np.ndarray) -> np.ndarray:
        """``(..., 4)`` physical -> normalised, the inverse of :meth:`to_physical` (not clipped)."""
        physical = np.asarray(physical, dtype=np.float64)
        span = self.action_high - self.action_low
        return 2.0 * (physical - self.action_low) / np.where(span == 0.0, 1.0, span) - 1.0

    # --- arguments --------------------------------------------------------------------------------

    def check_arguments(self, state: GeometricState, arguments: Sequence[str]) -> tuple[str, ...]:
        """Validate the arity, presence and kinds of ``arguments``; returns them as a tuple.

        Raises:
            ValueError: naming the problem and the signature.
        """
        arguments = tuple(arguments)
        signature = f"{self.name}({', '.join('|'.join(sorted(k.value for k in kinds)) for kinds in self.argument_kinds)})"
        if len(arguments) != len(self.argument_kinds):
            raise ValueError(f"{self.name} takes {len(self.argument_kinds)} argument(s), got {arguments}: {signature}")
        for position, (argument, kinds) in enumerate(zip(arguments, self.argument_kinds, strict=True)):
            if argument not in state.objects:
                raise ValueError(
                    f"{self.name}: argument {position} {argument!r} is not in the scene; present: "
                    f"{', '.join(state.object_names)}"
                )
            if object_spec(argument).kind not in kinds:
                raise ValueError(f"{self.name}: {argument!r} is a {object_spec(argument).kind.value}; expected {signature}")
        return arguments

    # --- execution contract -----------------------------------------------------------------------

    # --- geometric predictions --------------------------------------------------------------------

    screen_predictions: tuple[str, ...] = ("in_the_way",)
    """The predictions :meth:`screen_of_states` makes."""

    def in_the_way(self, state: GeometricState, arguments: Sequence[str], physical: np.ndarray) -> np.ndarray:
        """``(B,)`` whether each of ``(B, 4)`` physical actions is predicted to drive the gripper, a tool
        or the carried object into another object. A prediction from the domain's geometry only.

        Raises:
            NotImplementedError: a primitive that makes no such prediction.
        """
        raise NotImplementedError(f"{self.name} makes no geometric prediction")

    def screen_of_states(
        self, states: Sequence[GeometricState], arguments: Sequence[str], physical: np.ndarray, state_of: np.ndarray
    ) -> dict[str, np.ndarray]:
        """The geometric predictions (:attr:`screen_predictions`) of ``(B, 4)`` physical actions, action b
        taken in ``states[state_of[b]]`` (states holding the same objects), each ``(B,)`` bool. This
        default asks :meth:`in_the_way` once per state; a primitive that can judges the batch at once."""
        physical, state_of = np.asarray(physical, dtype=np.float64), np.asarray(state_of, dtype=np.int64)
        flags = np.zeros(len(physical), dtype=bool)
        order = np.argsort(state_of, kind="stable")
        for state, mine in zip(states, np.split(order, np.cumsum(np.bincount(state_of, minlength=len(states)))[:-1]), strict=True):
            if len(mine):
                flags[mine] = self.in_the_way(state, arguments, physical[mine])
        return {"in_the_way": flags}

    def precheck(self, state: GeometricState, arguments: Sequence[str], action: np.ndarray) -> str | None:
        """A failure reason that ends the primitive before any motion, or ``None``."""
        return None

    @abstractmethod
    def motion(self, state: GeometricState, arguments: Sequence[str], action: np.ndarray) -> tuple[MotionStep, ...]:
        """The sub-motions for the normalised ``action`` from ``state`` (only valid after :meth:`precheck`)."""

    def outcome(self, start_state: GeometricState, end_state: GeometricState, arguments: Sequence[str]) -> Outcome:
        """The post-conditions once every step ran without a failure."""
        return Outcome.ok()

    # --- action samplers --------------------------------------------------------------------------

    def heuristic_physical(self, state: GeometricState, arguments: Sequence[str], rng: np.random.Generator) -> np.ndarray:
        """``(4,)`` physical heuristic action; the default is uniform over the physical ranges."""
        return rng.uniform(self.action_low, self.action_high)

    def heuristic_action(self, state: GeometricState, arguments: Sequence[str], rng: np.random.Generator) -> np.ndarray:
        """``(4,) float64`` normalised heuristic action, clipped to ``[-1, 1]``."""
        return np.clip(self.to_normalized(self.heuristic_physical(state, arguments, rng)), -1.0, 1.0)

    def exploration_action(
        self, state: GeometricState, arguments: Sequence[str], rng: np.random.Generator
    ) -> np.ndarray:
        """``(4,) float64`` data-generation action: with probability 0.9 the heuristic action plus
        N(0, 0.05²) per dimension, clipped to ``[-1, 1]``; otherwise uniform in ``[-1, 1]⁴``."""
        return self._explore(self.heuristic_action, state, arguments, rng)

    def screened_physical(self, state: GeometricState, arguments: Sequence[str], rng: np.random.Generator) -> np.ndarray:
        """``(4,)`` physical action of the *screened heuristic*, the data-generation sampler: heuristic
        draws filtered by an analytic feasibility screen of the domain's geometry (no simulation).
        The default is the heuristic itself; Pull and Push screen (see ``sweep_screen``)."""
        return self.heuristic_physical(state, arguments, rng)

    def screened_action(self, state: GeometricState, arguments: Sequence[str], rng: np.random.Generator) -> np.ndarray:
        """``(4,) float64`` normalised :meth:`screened_physical` action, clipped to ``[-1, 1]``."""
        return np.clip(self.to_normalized(self.screened_physical(state, arguments, rng)), -1.0, 1.0)

    def screened_exploration_action(
        self, state: GeometricState, arguments: Sequence[str], rng: np.random.Generator
    ) -> np.ndarray:
        """:meth:`exploration_action` around :meth:`screened_action` instead of the plain heuristic."""
        return self._explore(self.screened_action, state, arguments, rng)

    def _explore(
        self, sampler: Callable[..., np.ndarray], state: GeometricState, arguments: Sequence[str], rng: np.random.Generator
    ) -> np.ndarray:
        if rng.random() < EXPLORATION_HEURISTIC_PROBABILITY:
            noisy = sampler(state, arguments, rng) + rng.normal(0.0, EXPLORATION_NOISE_STD, self.action_dim)
            return np.clip(noisy, -1.0, 1.0)
        return rng.uniform(-1.0, 1.0, self.action_dim)

    def __repr__(self) -> str:
        return f"<Primitive {self.name}>"


def other_objects(state: GeometricState, arguments: Sequence[str], *, include_table: bool) -> tuple[str, ...]:
    """The present objects that are not arguments, in state order; the static table only when asked
    (it cannot be disturbed, but guarded motions may have to avoid touching it)."""
    return tuple(
        name
        for name in state.objects
        if name not in arguments and (include_table or object_spec(name).kind is not ObjectKind.TABLE)
    )


def lift_position(xy: np.ndarray) -> np.ndarray:
    """``(3,)`` the waypoint at the lift height (0.40 m) directly above world ``xy``."""
    return np.array([xy[0], xy[1], MAX_LIFT_HEIGHT])


def first_disturbed(start_state: GeometricState, state: GeometricState, names: Sequence[str]) -> str | None:
    """``"disturbed"`` if any of ``names`` moved >= 0.05 m or rotated >= 5° between the two states
    (``did_move``), else ``None``. Objects missing from either state are skipped."""
    for name in names:
        if name in start_state.objects and name in state.objects:
            before, after = start_state.objects[name], state.objects[name]
            if did_move(before.position, before.quaternion, after.position, after.quaternion):
                return "disturbed"
    return None
