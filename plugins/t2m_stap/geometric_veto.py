"""The domain's geometry as a veto on planned actions (docs/guide/feasibility.md#geometric-veto).

An option of the sampling planners, empty by default (the method judges feasibility with the
learned Q-ensembles alone): ``veto`` names the skills whose actions get the value 0 where their
primitive's ``in_the_way`` predicts from the domain's geometry that they drive something into
another object. For Pull and Push: the hook, the swept box or the hand sweeping into a bystander;
for Place: the held object set down on or against one. Those are the failures the ensembles rate
highest: their data's sweeps were screened, and their placements rarely crowded.

A prediction reads one geometric state per step. At a plan's first step that is the observed
state; at later steps the trajectories' predicted states differ a little, and the veto reads their
element-wise median (the bystanders, which the veto is about, move little in the predictions of
steps that do not touch them). The median is taken over one batch of rolled-out trajectories, so
with a population above the planner's ``chunk_size`` a later step's veto reads one state per chunk.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import torch

from t2m_core.domain.observation import decode_observation
from t2m_core.domain.primitives import get_primitive
from t2m_core.domain.skills import SkillCall

Veto = Callable[[torch.Tensor, torch.Tensor], torch.Tensor]
"""``(observations (N, 8, 12) raw, actions (N, 4) normalised) -> (N,) bool``: the actions vetoed."""

def geometric_veto(call: SkillCall, object_names: Sequence[str]) -> Veto:
    """The veto of ``call``'s actions: its primitive's ``in_the_way`` prediction, batched over the
    actions at one reference state."""
    primitive = get_primitive(call.name)
    names = tuple(object_names)

    def veto(observations: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        reference = observations.median(dim=0).values  # the observed state itself at a plan's first step
        state = decode_observation(reference.numpy(), names)
        physical = primitive.to_physical(actions.numpy())
        return torch.from_numpy(np.asarray(primitive.in_the_way(state, call.args, physical), dtype=bool))

    return veto
