"""The six component protocols of t2m and the value types they exchange.

Every builtin plugin and every third-party plugin implements one of these. They are structural
(:class:`typing.Protocol`): a plugin never needs to import a base class, only to provide the methods.
Conformance checks for each live in :mod:`t2m_core.testing`.

Array conventions: NumPy arrays unless stated; shapes are given in docstrings as ``(N, 96) float32``.
Units: metres, radians, seconds.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol, TypeVar, runtime_checkable

if TYPE_CHECKING:
    import numpy as np
    import torch

    from t2m_core.domain.goals import Goal
    from t2m_core.domain.skills import SkillCall
    from t2m_core.domain.state import GeometricState
    from t2m_core.language.session import LanguageSession
    from t2m_core.tasks.model import Task


# --------------------------------------------------------------------------------------------------
# Simulator
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Contact:
    """One contact reported by a backend after a primitive: the two object (or robot link) names and
    the normal force in newtons."""

    body_a: str
    body_b: str
    normal_force: float = 0.0


@dataclass(frozen=True)
class ResetResult:
    """What :meth:`Simulator.reset` returns.

    Attributes:
        state: the settled, verified geometric state.
        observation: ``(8, 12) float32`` raw observation (docs/guide/world.md#observation-encoding).
        accepted_seed: the seed whose sample was accepted (``seed``, ``seed + 1``, ...).
        rejections: how many candidate seeds were rejected before it.
    """

    state: GeometricState
    observation: np.ndarray
    accepted_seed: int
    rejections: int = 0


@dataclass(frozen=True)
class PrimitiveResult:
    """Outcome of one primitive execution (one environment step of a skill).

    Attributes:
        success: reward 1 (the primitive's success test held).
        truncated: a control failure ended it (disturbance, contact, unreachable, failed grasp).
        failure: short machine-readable reason when ``success`` is false (``"unreachable"``,
            ``"collision"``, ``"disturbed"``, ``"grasp_failed"``, ``"dropped"``, ``"not_on_target"``, ...).
        state: geometric state after the primitive.
        observation: ``(8, 12) float32`` raw observation after the primitive.
        contacts: contacts observed during guarded motions.
        frames: ``(H, W, 3) uint8`` RGB frames when the simulator records video, else empty.
    """

    success: bool
    truncated: bool
    failure: str | None
    state: GeometricState
    observation: np.ndarray
    contacts: Sequence[Contact] = ()
    frames: Sequence[np.ndarray] = ()


@runtime_checkable
class Simulator(Protocol):
    """A physics backend for the TableEnv world.

    Backends only do physics (load the scene, move the arm through the domain's waypoints, open and
    close the gripper, report poses and contacts, render). Geometry, action ranges and success tests
    come from :mod:`t2m_core.domain`. Like gymnasium, seeding happens through :meth:`reset` and the
    render mode is fixed at construction.
    """

    def reset(self, task: Task, *, seed: int) -> ResetResult:
        """Sample the task's initial state for ``seed`` (trying ``seed + 1``... on rejection), settle
        and verify it."""
        ...

    def execute(self, primitive: str, arguments: Sequence[str], action: np.ndarray) -> PrimitiveResult:
        """Execute ``primitive`` (``"pick"``, ``"place"``, ``"pull"``, ``"push"``) on the named objects
        with the normalised ``(4,)`` action in ``[-1, 1]``."""
        ...

    def get_state(self) -> Any:
        """An opaque snapshot that :meth:`set_state` restores exactly (physics and controller)."""
        ...

    def set_state(self, snapshot: Any) -> None:
        """Restore a snapshot taken by :meth:`get_state`."""
        ...

    def geometric_state(self) -> GeometricState:
        """The current object poses and end effector."""
        ...

    def observation(self) -> np.ndarray:
        """``(8, 12) float32`` raw observation of the current state."""
        ...

    def render(self, camera: str | None = None, *, depth: bool = False) -> np.ndarray:
        """``(H, W, 3) uint8`` RGB, or ``(H, W) float32`` depth in metres, from a named camera."""
        ...

    def close(self) -> None:
        """Release native resources."""
        ...


# --------------------------------------------------------------------------------------------------
# Skill
# --------------------------------------------------------------------------------------------------


Batch = TypeVar("Batch", "np.ndarray", "torch.Tensor")
"""What :class:`Skill` methods take: NumPy arrays (the myopic planners, the conformance check) or torch
tensors (the STAP rollouts), all arguments of one kind; they answer in that kind."""


@runtime_checkable
class Skill(Protocol):
    """One entry of a skill library: a primitive plus its learned models.

    States are the 96-D skill-specific encodings (argument-first, normalised;
    docs/guide/skills.md#state-encodings); actions are normalised to ``[-1, 1]``. All methods are batched
    over the first axis and answer in the kind of their arguments (:data:`Batch`).
    """

    name: str
    """The primitive's name, e.g. ``"pick"``."""

    action_dim: int
    """Dimension of the normalised action (4 for every TableEnv primitive)."""

    ood_threshold: float
    """ε of the OOD detector: a (state, action) whose ensemble variance is ≥ ε is out of
    distribution (docs/guide/skills.md#ood-detection). The variance is the Q-ensemble members' unless
    the skill also defines ``ood_variance(states, actions, q_members) -> (N,)``, a separate detector's
    (:func:`t2m_core.ood.ood_variance`)."""

    def policy(self, states: Batch) -> Batch:
        """Deterministic action ``(N, 4)`` for ``(N, 96)`` states."""
        ...

    def q_values(self, states: Batch, actions: Batch) -> Batch:
        """Success probabilities of every ensemble member, ``(N, B)`` for ``(N, 96)``, ``(N, 4)``."""
        ...

    def predict(self, states: Batch, actions: Batch) -> Batch:
        """Predicted next dynamics state ``(N, 96)`` (docs/guide/skills.md#dynamics)."""
        ...


# --------------------------------------------------------------------------------------------------
# Feasibility planner
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class PlanResult:
    """Output of a feasibility planner for a skill sequence of length ``T`` (docs/guide/feasibility.md#interface).

    Attributes:
        actions: ``(T, 4) float32`` normalised parameters.
        states: ``(T + 1, 8, 12) float32`` the given state and the predicted ones.
        values: ``(T,) float32`` per-step ``clip(min_i Q_i, 0, 1)``.
        ood: ``(T,) bool`` per-step out-of-distribution flags.
        p_success: product of the OOD-masked values, Π_t v_t·(1 − ood_t).
        variances: ``(T,) float32`` the OOD statistic per step, population variance of the ensemble
            members or of the skill's separate detector (what the OOD flags threshold), or ``None``.
        q_members: ``(T, B) float32`` every member's success probability per step, or ``None``.
    """

    actions: np.ndarray
    states: np.ndarray
    values: np.ndarray
    ood: np.ndarray
    p_success: float
    variances: np.ndarray | None = None
    q_members: np.ndarray | None = None


@runtime_checkable
class FeasibilityPlanner(Protocol):
    """Optimises the continuous parameters of a skill sequence through learned dynamics."""

    def plan(
        self,
        observation: np.ndarray,
        skeleton: Sequence[SkillCall],
        skills: Mapping[str, Skill],
        object_names: Sequence[str],
        *,
        initial_actions: np.ndarray | None = None,
    ) -> PlanResult:
        """Plan ``skeleton`` from the ``(8, 12)`` observation whose rows ``1..N`` are ``object_names``.

        ``initial_actions``: ``(T0, 4)`` normalised actions for the first ``T0 <= len(skeleton)``
        skills, typically the plan already made for that prefix, where a search may start (PolicyCEM
        takes them, and the policies' actions after them, as its starting mean). A hint: a planner
        may ignore it, and callers pass it only when asked to (``LookaheadOptions.prefix_start``,
        ``run.replan_start``).
        """
        ...


# --------------------------------------------------------------------------------------------------
# Language model
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class LanguageModelCapabilities:
    """What a backend can do.

    Attributes:
        exact_scoring: :meth:`LanguageModel.score` returns exact log-likelihoods of the candidates
            (False: an approximation, e.g. labelled multiple choice over top-k log-probabilities).
        grammar: :meth:`LanguageModel.complete` accepts a GBNF grammar for constrained decoding.
    """

    exact_scoring: bool = False
    grammar: bool = False


@runtime_checkable
class LanguageModel(Protocol):
    """Text in, text out, plus scoring of candidate continuations."""

    capabilities: LanguageModelCapabilities

    def complete(
        self,
        prompt: str,
        *,
        max_tokens: int = 256,
        stop: Sequence[str] = (),
        temperature: float = 0.0,
        n: int = 1,
        grammar: str | None = None,
    ) -> list[str]:
        """``n`` completions of ``prompt``."""
        ...

    def score(self, prompt: str, candidates: Sequence[str]) -> list[float]:
        """Log-likelihood (nats) of each candidate as a continuation of ``prompt``."""
        ...


# --------------------------------------------------------------------------------------------------
# Scene parser
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SceneObservation:
    """Everything a scene parser may look at.

    Attributes:
        object_names: the task's objects, in order (``table`` first).
        rgb: ``(H, W, 3) uint8`` colour image, if a camera is available.
        depth: ``(H, W) float32`` depth in metres, aligned with ``rgb``.
        intrinsics: ``(3, 3) float64`` pinhole camera matrix.
        camera_pose: ``(4, 4) float64`` camera-to-world transform.
        ground_truth: the simulator's geometric state, when parsing from simulation.
    """

    object_names: Sequence[str]
    rgb: np.ndarray | None = None
    depth: np.ndarray | None = None
    intrinsics: np.ndarray | None = None
    camera_pose: np.ndarray | None = None
    ground_truth: GeometricState | None = None
    extra: Mapping[str, Any] = field(default_factory=dict)


@runtime_checkable
class SceneParser(Protocol):
    """Turns an observation into the geometric state (object poses; sizes come from the object specs)."""

    def parse(self, observation: SceneObservation) -> GeometricState:
        """The geometric state of the scene in ``observation``."""
        ...


# --------------------------------------------------------------------------------------------------
# Task planner
# --------------------------------------------------------------------------------------------------


@dataclass
class PlanningContext:
    """Everything a task planner works with for one episode.

    Attributes:
        instruction: the human instruction.
        goal: the predicted goal; lookahead planners stop on it, the myopic baselines only show it to
            the language model.
        session: the scene's language session (prompts, queries).
        skills: skill name -> :class:`Skill`.
        feasibility: the :class:`FeasibilityPlanner` (STAP).
        object_names: the present objects in observation-row order.
        observation: ``(8, 12) float32`` the observation planning starts from.
        simulator: the :class:`Simulator`, for planners that interleave planning and execution (the
            myopic baselines); ``None`` otherwise.
        on_event: receives every plan-tree record (candidates, scores, decisions) as a JSON-ready dict.
    """

    instruction: str
    goal: Goal
    session: LanguageSession
    skills: Mapping[str, Skill]
    feasibility: FeasibilityPlanner
    object_names: Sequence[str]
    observation: np.ndarray
    simulator: Simulator | None = None
    on_event: Callable[[dict[str, Any]], None] | None = None


@dataclass
class TaskPlan:
    """What a task planner returns.

    Attributes:
        skeleton: the chosen skill sequence; for the myopic baselines, what they executed.
        plan: the feasibility plan of ``skeleton`` from the start (``None`` when planning failed or
            for planners that executed as they went).
        failure: why planning failed, or ``None``.
        executed: ``True`` when the planner already executed its skills (myopic baselines).
        llm_calls, stap_calls: how many language-model requests and feasibility plans it made.
    """

    skeleton: Sequence[SkillCall]
    plan: PlanResult | None
    failure: str | None = None
    executed: bool = False
    llm_calls: int = 0
    stap_calls: int = 0

    @property
    def found(self) -> bool:
        """A plan was found (not a planning failure)."""
        return self.failure is None


@runtime_checkable
class TaskPlanner(Protocol):
    """The language-level search (hybrid, shooting, greedy-search, saycan-gs, innermono-gs)."""

    def plan(self, context: PlanningContext) -> TaskPlan:
        """Search for a skill sequence whose predicted final state satisfies ``context.goal``."""
        ...
