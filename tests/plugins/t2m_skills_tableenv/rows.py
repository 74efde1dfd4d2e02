"""Random argument-first rows for the relational networks' tests."""

from __future__ import annotations

import numpy as np
import torch

from t2m_core.domain.observation import normalize

EMPTY = torch.from_numpy(normalize(np.zeros(12, dtype=np.float32)))
"""A raw all-zero row (an empty slot), normalised."""


def rows(count: int, seed: int) -> torch.Tensor:
    """``(count, 8, 12)`` rows uniform in [−0.5, 0.5), reproducible from ``seed``."""
    return torch.rand(count, 8, 12, generator=torch.Generator().manual_seed(seed)) - 0.5
