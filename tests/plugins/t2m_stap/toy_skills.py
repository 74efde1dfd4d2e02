"""Analytic stand-ins for learned skills, for testing feasibility planners: the best action of each
is known, so a planner's answer can be judged without training anything."""

from __future__ import annotations

import torch


class ToySkill:
    """Q is high when the action is near ``target``; in ``chained`` mode step 2's target is what
    step 1 wrote into the state (the first argument's x feature), so the two steps depend on each
    other. The dynamics write the action's first component into that feature (normalised units)."""

    action_dim = 4

    def __init__(self, name: str, target: tuple[float, ...] = (0.6, -0.4, 0.2, 0.0), policy_action=(0.0, 0.0, 0.0, 0.0),
                 chained: bool = False, members: int = 8, ood_threshold: float = 0.2) -> None:
        self.name = name
        self.target = torch.tensor(target)
        self.policy_action = torch.tensor(policy_action)
        self.chained = chained
        self.spread = torch.linspace(0.98, 1.0, members)
        self.ood_threshold = ood_threshold

    def policy(self, states: torch.Tensor) -> torch.Tensor:
        return self.policy_action.expand(states.shape[0], 4).clone()

    def q_values(self, states: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        target = self.target.expand(actions.shape[0], 4).clone()
        if self.chained:
            target[:, 0] = states[:, 12] * 2  # the first argument's normalised x (row 1, feature 0)
        quality = torch.exp(-((actions - target) ** 2).sum(dim=1) / 0.1)
        return quality[:, None] * self.spread[None, :]

    def predict(self, states: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        next_states = states.clone()
        next_states[:, 12] = actions[:, 0] * 0.4  # moves the first argument along x
        return next_states
