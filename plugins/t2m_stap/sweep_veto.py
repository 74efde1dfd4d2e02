"""The domain's geometry as a veto on planned hook sweeps (docs/guide/feasibility.md#sweep-veto).

An option of the sampling planners, off by default (the method judges feasibility with the learned
Q-ensembles alone). With it, a Pull or Push action that the domain's analytic sweep prediction
(:meth:`~t2m_core.domain.primitives.hook_sweep.HookSweep.in_the_way`) expects to drive the hook,
the swept box or the hand into another object gets the value 0 at that step, whatever its
ensemble says: the failure the ensembles trained on screened data rate highest.

The prediction reads one geometric state per step. At a plan's first step that is the observed
state; at later steps the trajectories' predicted states differ a little, and the veto reads their
element-wise median (the bystanders, which the veto is about, move little in the predictions of
steps that do not touch them).
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


def sweep_veto(call: SkillCall, object_names: Sequence[str]) -> Veto | None:
    """The veto of ``call``'s actions, or ``None`` for a skill without a sweep prediction (Pick, Place)."""
    primitive = get_primitive(call.name)
    in_the_way = getattr(primitive, "in_the_way", None)
    if in_the_way is None:
        return None
    names = tuple(object_names)

    def veto(observations: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        reference = observations.median(dim=0).values if observations.shape[0] > 1 else observations[0]
        state = decode_observation(reference.numpy(), names)
        physical = primitive.to_physical(actions.numpy())
        return torch.from_numpy(np.asarray(in_the_way(state, call.args, physical), dtype=bool))

    return veto
