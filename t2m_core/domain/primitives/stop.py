"""Stop(): the language baselines' "done" skill (docs/guide/planners.md#saycan-gs): no motion, always succeeds."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from t2m_core.domain.primitives.base import MotionStep, Primitive
from t2m_core.domain.state import GeometricState


class Stop(Primitive):
    """No arguments, no motion, no policy; its 4-D action is ignored."""

    name = "stop"
    argument_kinds = ()
    action_low = -np.ones(4)
    action_high = np.ones(4)

    def motion(self, state: GeometricState, arguments: Sequence[str], action: np.ndarray) -> tuple[MotionStep, ...]:
        self.check_arguments(state, arguments)
        return ()
