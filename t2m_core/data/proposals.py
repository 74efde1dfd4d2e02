"""The ``proposal`` action sampler: the actions a feasibility planner would try with a given skill
library (docs/guide/skills.md#proposal-data).

The screened sampler covers the actions a hand-written heuristic finds plausible. A planner does not
sample there: PolicyCEM starts from the policy's action with noise of σ = 0.3 and converges on the
actions the Q-ensemble scores highest. Where the ensemble is confidently wrong, and the screened data
hold no failure to say otherwise, the optimiser finds exactly those actions. Simulating them, and
training on the outcome, is the DAgger-style correction: each draw of this sampler is, with equal
probability,

- ``screened``: the screened exploration sampler (keeps the data's coverage);
- ``policy``: the policy's deterministic action plus N(0, σ²) per dimension, clipped to [−1, 1] (the
  planner's first population);
- ``optimum``: of :data:`OPTIMUM_CANDIDATES` such noisy policy actions, the one with the highest
  min-of-ensemble Q (where the optimiser goes).

The sampler depends on the checkpoint it proposes with, so a dataset records that checkpoint's
digest (:func:`checkpoint_digest`); chunks stay pure functions of their spec and that checkpoint.
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from t2m_core.domain.observation import argument_first_order, skill_state
from t2m_core.domain.primitives import Primitive
from t2m_core.domain.state import GeometricState
from t2m_core.errors import T2MError

PROPOSAL_NOISE = 0.3
"""σ of the Gaussian around the policy's action, normalised units: PolicyCEM's constant σ."""
OPTIMUM_CANDIDATES = 256
"""Noisy policy actions among which an ``optimum`` draw takes the best by min-of-ensemble Q."""
MODES: tuple[str, ...] = ("screened", "policy", "optimum")
"""The sampler's draws, each with probability 1/3."""
CHECKPOINT_FILES: tuple[str, ...] = ("config.json", "*.safetensors")
"""What a skill checkpoint's digest covers (its model and configuration, not its logs or plots)."""


class ProposalError(T2MError):
    """A proposal checkpoint that is missing or differs from the one a dataset was made with."""


def checkpoint_digest(checkpoints: Path | str, skill: str) -> str:
    """sha256 over ``checkpoints/<skill>``'s configuration and weight files, in name order.

    Raises:
        ProposalError: the skill's checkpoint directory has no such file.
    """
    directory = Path(checkpoints) / skill
    files = sorted({path for pattern in CHECKPOINT_FILES for path in directory.glob(pattern)})
    if not files:
        raise ProposalError(f"no {skill} checkpoint in {directory}", "point --proposal-checkpoints at a directory written by `t2m train --out`")
    digest = hashlib.sha256()
    for path in files:
        digest.update(path.name.encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()


class ProposalSampler:
    """Draw data-generation actions for one skill as a planner with ``skill`` would propose them.

    Args:
        primitive: the skill's primitive (its screened exploration sampler).
        skill: the learned skill (:class:`t2m_core.protocols.Skill`): ``policy`` and ``q_values``.
    """

    def __init__(self, primitive: Primitive, skill: Any) -> None:
        self.primitive = primitive
        self.skill = skill

    def policy_action(self, observation: np.ndarray, objects: tuple[str, ...], arguments: tuple[str, ...]) -> tuple[np.ndarray, np.ndarray]:
        """The skill state ``(96,)`` of ``observation`` ``(8, 12)`` and the policy's action ``(4,)`` there."""
        state = skill_state(np.asarray(observation, dtype=np.float32), argument_first_order(objects, arguments)).astype(np.float32)
        return state, np.asarray(self.skill.policy(state[None]), dtype=np.float64)[0]

    def draw(self, state: GeometricState, arguments: tuple[str, ...], skill_state_: np.ndarray, policy_action: np.ndarray,
             rng: np.random.Generator) -> np.ndarray:
        """One action ``(4,)`` in [−1, 1] for the scene whose skill state and policy action
        :meth:`policy_action` computed (``state``: its geometric state, for the screened draws)."""
        mode = MODES[int(rng.integers(len(MODES)))]
        if mode == "screened":
            return self.primitive.screened_exploration_action(state, arguments, rng)
        if mode == "policy":
            return np.clip(policy_action + rng.normal(0.0, PROPOSAL_NOISE, policy_action.shape), -1.0, 1.0)
        return self.optimum(skill_state_, policy_action, rng)

    def optimum(self, skill_state_: np.ndarray, policy_action: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Of :data:`OPTIMUM_CANDIDATES` noisy policy actions ``(4,)``, the one with the highest
        min-of-ensemble Q (a one-step stand-in for where the planner's optimiser goes)."""
        candidates = np.clip(policy_action + rng.normal(0.0, PROPOSAL_NOISE, (OPTIMUM_CANDIDATES, policy_action.size)), -1.0, 1.0)
        states = np.broadcast_to(skill_state_, (OPTIMUM_CANDIDATES, skill_state_.size))
        values = np.asarray(self.skill.q_values(states, candidates.astype(np.float32))).min(axis=1)
        return candidates[int(np.argmax(values))]


def library_digest(checkpoints: Path | str, skills: tuple[str, ...]) -> str:
    """sha256 over the :func:`checkpoint_digest` of each of ``skills`` (in that order): what a task
    rollout depends on, since it advances with every skill of a skeleton.

    Raises:
        ProposalError: a skill has no checkpoint in ``checkpoints``.
    """
    digest = hashlib.sha256()
    for skill in skills:
        digest.update(skill.encode() + b"\0" + checkpoint_digest(checkpoints, skill).encode())
    return digest.hexdigest()


_WORKER_LIBRARIES: dict[tuple[str, str, str], dict[str, Any]] = {}


def load_proposal_library(library: str, checkpoints: Path | str, digest: str, found: Callable[[], str], what: str) -> dict[str, Any]:
    """Skill library ``library`` loaded from ``checkpoints`` (once per process, after checking that
    ``found()`` still equals the recorded ``digest``; ``what`` names the checkpoint in the error).
    The library's options must take ``checkpoints``, as the ``tableenv`` library's do.

    Raises:
        ProposalError: the checkpoint changed since the dataset was started.
    """
    key = (library, str(Path(checkpoints).resolve()), digest)
    skills = _WORKER_LIBRARIES.get(key)
    if skills is None:
        current = found()
        if current != digest:
            raise ProposalError(
                f"the {what} in {checkpoints} changed since this dataset was started (digest {current[:12]}, recorded {digest[:12]})",
                "extend the dataset with the checkpoint it was made with, or write the new proposals to another --out",
            )
        from t2m_core.registry import get_registry

        skills = _WORKER_LIBRARIES[key] = get_registry().create("skill_library", library, {"checkpoints": Path(checkpoints)})
    return skills


def load_proposal_sampler(primitive: Primitive, library: str, checkpoints: Path | str, digest: str) -> ProposalSampler:
    """The sampler for ``primitive`` with skill library ``library`` loaded from ``checkpoints``
    (:func:`load_proposal_library`; ``digest``: the :func:`checkpoint_digest` of its skill).

    Raises:
        ProposalError: the checkpoint changed since the dataset was started.
    """
    skills = load_proposal_library(library, checkpoints, digest, lambda: checkpoint_digest(checkpoints, primitive.name), f"{primitive.name} checkpoint")
    return ProposalSampler(primitive, skills[primitive.name])
