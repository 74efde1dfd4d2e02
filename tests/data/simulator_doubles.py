"""A scripted stand-in for a simulator in data-generation tests: it resets to analytically sampled
scenes and succeeds by a rule of the action that the tests choose (no physics)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from t2m_core.domain.observation import encode_observation
from t2m_core.domain.sampling import sample_initial_state
from t2m_core.protocols import PrimitiveResult, ResetResult


class ScriptedSimulator:
    """Succeeds when ``rule(action)`` holds; ``interrupt_after`` executions raise KeyboardInterrupt
    (a killed run)."""

    def __init__(self, rule: Callable[[np.ndarray], bool], interrupt_after: int | None = None) -> None:
        self.rule = rule
        self.interrupt_after = interrupt_after
        self.executions = 0
        self.objects: tuple[str, ...] = ()

    def reset(self, task, *, seed: int) -> ResetResult:
        sampled = sample_initial_state(task.objects, task.initial_state, seed)
        self.objects, self.state = tuple(task.objects), sampled.state
        return ResetResult(sampled.state, encode_observation(sampled.state, self.objects), sampled.accepted_seed, sampled.rejections)

    def execute(self, primitive, arguments, action) -> PrimitiveResult:
        self.executions += 1
        if self.interrupt_after is not None and self.executions > self.interrupt_after:
            raise KeyboardInterrupt
        success = bool(self.rule(np.asarray(action)))
        observation = encode_observation(self.state, self.objects)
        return PrimitiveResult(success, not success, None if success else "collision", self.state, observation)
