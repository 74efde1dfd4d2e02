"""A skill's dataset as tensors for training (docs/guide/skills.md#state-encodings).

States are stored as normalised, argument-first rows ``(N, 8, 12)``; a training batch shuffles the
rows of each sample's non-argument objects (its shuffle range) so that the networks learn to ignore
their order, and is flattened to ``(B, 96)``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from t2m_core.data.generate import load_split
from t2m_core.data.records import Transitions
from t2m_core.domain.observation import reordered_rows
from t2m_core.errors import T2MError


@dataclass
class SkillTensors:
    """One split of one skill.

    Attributes:
        rows: ``(N, 8, 12) float32`` normalised argument-first rows before the primitive.
        next_rows: ``(N, 8, 12) float32`` the rows after it, in the same order.
        shuffle_range: ``(N, 2) int64`` start and stop of the shuffled rows.
        actions: ``(N, 4) float32``; rewards ``(N,) float32``.
    """

    rows: torch.Tensor
    next_rows: torch.Tensor
    shuffle_range: torch.Tensor
    actions: torch.Tensor
    rewards: torch.Tensor

    def __len__(self) -> int:
        return int(self.rewards.shape[0])

    @classmethod
    def from_transitions(cls, transitions: Transitions) -> SkillTensors:
        orders = transitions.row_order.astype(np.int64)
        return cls(
            rows=torch.from_numpy(reordered_rows(transitions.observation, orders)),
            next_rows=torch.from_numpy(reordered_rows(transitions.next_observation, orders)),
            shuffle_range=torch.from_numpy(transitions.shuffle_range.astype(np.int64)),
            actions=torch.from_numpy(transitions.action.astype(np.float32)),
            rewards=torch.from_numpy(transitions.reward.astype(np.float32)),
        )

    @classmethod
    def load(cls, directory: Path, *more: Path) -> SkillTensors:
        """Load ``DIR/<skill>/<split>``, followed by the transitions of any ``more`` split directories."""
        return cls.from_transitions(Transitions.concatenate([load_split(d) for d in (directory, *more)]))

    def head(self, count: int | None) -> SkillTensors:
        """The first ``count`` samples (all when ``None``).

        Raises:
            T2MError: ``count`` exceeds the samples there are.
        """
        if count is None:
            return self
        if count > len(self):
            raise T2MError(f"asked for the first {count} training transitions, the split has {len(self)}", f"generate more with `t2m datagen --size {count}`")
        return SkillTensors(self.rows[:count], self.next_rows[:count], self.shuffle_range[:count], self.actions[:count], self.rewards[:count])

    def successes(self) -> SkillTensors:
        """The successful transitions only (what dynamics trains on)."""
        keep = self.rewards > 0.5
        return SkillTensors(self.rows[keep], self.next_rows[keep], self.shuffle_range[keep], self.actions[keep], self.rewards[keep])

    def states(self, index: torch.Tensor | slice = slice(None), generator: torch.Generator | None = None) -> torch.Tensor:
        """``(B, 96)`` states of the samples ``index``, shuffled within their ranges when a
        ``generator`` is given (training), in the stored order otherwise."""
        rows = self.rows[index]
        if generator is not None:
            rows = shuffle_rows(rows, self.shuffle_range[index], generator)
        return rows.reshape(rows.shape[0], -1)


def shuffle_rows(rows: torch.Tensor, shuffle_range: torch.Tensor, generator: torch.Generator) -> torch.Tensor:
    """Permute each sample's rows ``[start, stop)`` at random, the others in place.

    Args:
        rows: ``(B, 8, 12)``. shuffle_range: ``(B, 2)`` start, stop per sample.
    """
    batch, count = rows.shape[0], rows.shape[1]
    positions = torch.arange(count, dtype=torch.float32).expand(batch, count)
    start, stop = shuffle_range[:, :1].float(), shuffle_range[:, 1:].float()
    inside = (positions >= start) & (positions < stop)
    # keys inside the range are uniform in [start, stop): sorting them permutes only those rows
    keys = torch.where(inside, start + torch.rand(batch, count, generator=generator) * (stop - start), positions)
    order = keys.argsort(dim=1)
    return rows.gather(1, order[..., None].expand(-1, -1, rows.shape[2]))
