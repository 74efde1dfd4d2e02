"""The feasibility planners (docs/guide/feasibility.md#policycem, #baselines).

Each implements :class:`t2m_core.protocols.FeasibilityPlanner`: ``plan(observation, skeleton,
skills, object_names) -> PlanResult``. All are deterministic for their ``seed``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import torch

from t2m_core.domain.primitives import get_primitive
from t2m_core.domain.skills import SkillCall
from t2m_core.protocols import PlanResult, Skill
from t2m_stap.options import CEMOptions, PolicyOptions, RandomCEMOptions, SamplingOptions, ShootingOptions
from t2m_stap.rollout import Rollouts, Step, prepare_steps, rollout, rollout_in_chunks, thresholds_of, with_detectors


def _observation(observation: np.ndarray) -> torch.Tensor:
    tensor = torch.as_tensor(np.asarray(observation, dtype=np.float32))
    if tensor.shape != (8, 12):
        raise ValueError(f"expected an (8, 12) observation, got shape {tuple(tensor.shape)}")
    return tensor


def plan_result(rollouts: Rollouts, index: int, thresholds: torch.Tensor, steps: Sequence[Step]) -> PlanResult:
    """The :class:`PlanResult` of trajectory ``index``: its values, OOD flags (from the skills'
    detectors, :func:`~t2m_stap.rollout.with_detectors`) and the masked product."""
    chosen = with_detectors(steps, rollouts, index)
    ood = chosen.ood(thresholds)[0]
    values = chosen.values[0]
    return PlanResult(
        actions=chosen.actions[0].numpy().astype(np.float32),
        states=chosen.states[0].numpy().astype(np.float32),
        values=values.numpy().astype(np.float32),
        ood=ood.numpy(),
        p_success=float((values * (~ood)).prod()),
        variances=chosen.variances[0].numpy().astype(np.float32),
        q_members=chosen.q_members[0].numpy().astype(np.float32),
    )


def scores(rollouts: Rollouts, steps: Sequence[Step], thresholds: torch.Tensor, ood_penalty: bool) -> torch.Tensor:
    """``(N,)`` what a search ranks: the product of the values, OOD-masked (with the skills'
    detectors) when ``ood_penalty``."""
    if not ood_penalty:
        return rollouts.p_success()
    return with_detectors(steps, rollouts).p_success(thresholds)


def _empty_plan(observation: torch.Tensor) -> PlanResult:
    return PlanResult(
        np.zeros((0, 4), np.float32), observation.numpy()[None].copy(), np.zeros(0, np.float32), np.zeros(0, bool), 1.0,
        np.zeros(0, np.float32), np.zeros((0, 0), np.float32),
    )


def _initial_actions(initial_actions: np.ndarray | None, horizon: int) -> torch.Tensor | None:
    if initial_actions is None:
        return None
    tensor = torch.as_tensor(np.asarray(initial_actions, dtype=np.float32))
    if tensor.ndim != 2 or tensor.shape[1] != 4 or tensor.shape[0] > horizon:
        raise ValueError(f"initial_actions must be (T0, 4) with T0 <= {horizon} skills, got shape {tuple(tensor.shape)}")
    return tensor.clamp(-1.0, 1.0)


class FeasibilityPlannerBase:
    """What every planner here does around its search: check the observation, prepare the skeleton's
    steps and thresholds, and turn the chosen trajectory into a :class:`PlanResult`."""

    options: SamplingOptions | PolicyOptions

    def plan(
        self,
        observation: np.ndarray,
        skeleton: Sequence[SkillCall],
        skills: Mapping[str, Skill],
        object_names: Sequence[str],
        *,
        initial_actions: np.ndarray | None = None,
    ) -> PlanResult:
        start = _observation(observation)
        if not skeleton:
            return _empty_plan(start)
        prefix_actions = _initial_actions(initial_actions, len(skeleton))
        steps = prepare_steps(
            skeleton, skills, object_names, vetoed=frozenset(self.options.veto), vetoed_first=frozenset(self.options.veto_first)
        )
        thresholds = thresholds_of(steps)
        rollouts, index = self.search(start, steps, thresholds, prefix_actions)
        return plan_result(rollouts, index, thresholds, steps)

    def search(self, start: torch.Tensor, steps: list[Step], thresholds: torch.Tensor, prefix_actions: torch.Tensor | None) -> tuple[Rollouts, int]:
        """The rollouts holding the chosen trajectory, and its index. ``prefix_actions``: ``(T0, 4)``
        actions for the first steps, where the search may start (the protocol's ``initial_actions``)."""
        raise NotImplementedError


def action_bounds(steps: Sequence[Step], *, clip_grasps: bool = False) -> tuple[torch.Tensor, torch.Tensor]:
    """``((T, 4), (T, 4))`` normalised bounds of each step's sampled actions: [−1, 1], and with
    ``clip_grasps`` a grasp of a box kept 1 cm inside its faces
    (:meth:`~t2m_core.domain.primitives.pick.Pick.grasp_bounds`)."""
    low, high = torch.full((len(steps), 4), -1.0), torch.full((len(steps), 4), 1.0)
    if clip_grasps:
        pick = get_primitive("pick")
        for t, step in enumerate(steps):
            if step.call.name == "pick":
                bounds = pick.grasp_bounds(step.call.args)
                low[t], high[t] = (torch.from_numpy(pick.to_normalized(b).astype(np.float32)) for b in bounds)
    return low, high


class PolicyRollout(FeasibilityPlannerBase):
    """``policy``: one deterministic rollout of the skills' policies; reports its Q product."""

    def __init__(self, options: PolicyOptions | None = None) -> None:
        self.options = options or PolicyOptions()

    def search(self, start: torch.Tensor, steps: list[Step], thresholds: torch.Tensor, prefix_actions: torch.Tensor | None) -> tuple[Rollouts, int]:
        return rollout(steps, start), 0  # the policy alone: a starting point is not its to take


class CrossEntropyMethod(FeasibilityPlannerBase):
    """``policy-cem`` (``initial="policy"``, the default feasibility planner) and ``random-cem``
    (``initial="random"``): the cross-entropy method over the whole skeleton's actions. Given
    ``prefix_actions``, PolicyCEM's starting mean takes them at the first steps and the policies'
    actions after them."""

    def __init__(self, options: CEMOptions | None = None, initial: str = "policy") -> None:
        self.options = options or CEMOptions()
        self.initial = initial

    def search(self, start: torch.Tensor, steps: list[Step], thresholds: torch.Tensor, prefix_actions: torch.Tensor | None) -> tuple[Rollouts, int]:
        generator = torch.Generator().manual_seed(self.options.seed)
        policy_mean = rollout(steps, start, prefix_actions=prefix_actions).actions[0] if self.initial == "policy" else None
        best: tuple[float, Rollouts, int] | None = None
        for _ in range(self.options.restarts):  # one random stream: the first run is the same for any restarts
            mean = policy_mean if policy_mean is not None else torch.rand((len(steps), 4), generator=generator) * 2 - 1
            found = self._run(start, steps, thresholds, mean, generator)
            if best is None or found[0] > best[0]:
                best = found
        assert best is not None
        return best[1], best[2]

    def _run(
        self, start: torch.Tensor, steps: list[Step], thresholds: torch.Tensor, mean: torch.Tensor, generator: torch.Generator
    ) -> tuple[float, Rollouts, int]:
        """One CEM run from the starting mean ``(T, 4)``: its best score, the rollouts holding its best
        trajectory, and that trajectory's index."""
        options = self.options
        horizon = len(steps)
        low, high = action_bounds(steps, clip_grasps=options.clip_grasps)
        # sigma is a fraction of each dimension's range: a box grasp's clipped x and y are searched on the
        # box's scale, not piled on its bounds (the same as options.sigma without clip_grasps)
        sigma = options.sigma * (high - low) / 2
        samples_per_iteration = options.samples(horizon)
        best: tuple[float, Rollouts, int] | None = None
        elites: torch.Tensor | None = None
        for _ in range(options.iterations):
            actions = (mean + sigma * torch.randn((samples_per_iteration, horizon, 4), generator=generator)).clamp(low, high)
            kept = 0
            if elites is not None and options.keep_elites:
                kept = min(len(elites), samples_per_iteration)
                actions[:kept] = elites[:kept]
            if kept < samples_per_iteration:
                # the mean itself is always one candidate (unclamped without clip_grasps, as published)
                actions[kept] = mean.clamp(low, high) if options.clip_grasps else mean
            rollouts = rollout_in_chunks(steps, start, actions, options.chunk_size)
            ranked = scores(rollouts, steps, thresholds, options.ood_penalty)
            top = torch.topk(ranked, min(options.elites, samples_per_iteration)).indices
            if best is None or float(ranked[top[0]]) > best[0]:
                best = (float(ranked[top[0]]), rollouts, int(top[0]))
            elites = actions[top]
            mean = elites.mean(dim=0)
            if options.sigma_mode == "adaptive":
                sigma = elites.std(dim=0, unbiased=False).clamp_min(1e-4) if len(elites) > 1 else sigma
        assert best is not None
        return best


class Shooting(FeasibilityPlannerBase):
    """``policy-shooting`` (``initial="policy"``: the policies' actions at every predicted state plus
    N(0, σ²) noise) and ``random-shooting`` (uniform actions): one pass, the best trajectory wins."""

    def __init__(self, options: ShootingOptions | None = None, initial: str = "policy") -> None:
        self.options = options or ShootingOptions()
        self.initial = initial

    def search(self, start: torch.Tensor, steps: list[Step], thresholds: torch.Tensor, prefix_actions: torch.Tensor | None) -> tuple[Rollouts, int]:
        options = self.options  # one pass of fresh samples: a starting point is not used
        generator = torch.Generator().manual_seed(options.seed)
        total = options.samples(len(steps))
        best: tuple[float, Rollouts, int] | None = None
        for begin in range(0, total, options.chunk_size):
            count = min(options.chunk_size, total - begin)
            if self.initial == "policy":
                rollouts = rollout(steps, start, count=count, policy_noise=options.sigma, generator=generator)
            else:
                actions = torch.rand((count, len(steps), 4), generator=generator) * 2 - 1
                rollouts = rollout(steps, start, actions)
            ranked = scores(rollouts, steps, thresholds, options.ood_penalty)
            top = int(torch.argmax(ranked))
            if best is None or float(ranked[top]) > best[0]:
                best = (float(ranked[top]), rollouts, top)
        assert best is not None
        return best[1], best[2]


def policy_cem(options: CEMOptions) -> CrossEntropyMethod:
    return CrossEntropyMethod(options, "policy")


def random_cem(options: RandomCEMOptions) -> CrossEntropyMethod:
    return CrossEntropyMethod(options, "random")


def policy_shooting(options: ShootingOptions) -> Shooting:
    return Shooting(options, "policy")


def random_shooting(options: ShootingOptions) -> Shooting:
    return Shooting(options, "random")


def policy_only(options: PolicyOptions) -> PolicyRollout:
    return PolicyRollout(options)


__all__ = ["CrossEntropyMethod", "FeasibilityPlannerBase", "PolicyRollout", "SamplingOptions", "Shooting"]
