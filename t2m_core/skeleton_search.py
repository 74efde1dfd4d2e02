"""A bounded depth-first search for parameters that execute a skill skeleton in a simulator.

For each skill of the skeleton it samples parameters (the domain's heuristic action first, then its
exploration sampler: heuristic plus noise, sometimes uniform), executes them from a restored
snapshot and keeps the first that succeeds. When a skill exhausts its tries, the search backs up
and samples an earlier skill again. It checks a backend and its primitives; it is not a planner.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

TRIES_PER_SKILL = 25
"""Executions of one skill from a new start state before the search backs up."""
RETRIES_AFTER_BACKTRACK = 3
"""Executions of a skill revisited because a later skill exhausted its tries."""
MAX_EXECUTIONS = 600
"""Executions of the whole search before it gives up."""


@dataclass
class SkeletonSearch:
    """Result of :func:`search_skeleton`.

    Attributes:
        actions: ``(4,)`` normalised action of every skill that succeeded, in order.
        tries: executions spent on each skill of the skeleton (all visits).
        found: every skill succeeded.
        failures: failure reason -> count over all executions.
        executions: total primitive executions.
    """

    actions: list[np.ndarray] = field(default_factory=list)
    tries: list[int] = field(default_factory=list)
    found: bool = False
    failures: dict[str, int] = field(default_factory=dict)
    executions: int = 0


def search_skeleton(
    simulator: Any,
    skeleton: Sequence[Any],
    rng: np.random.Generator,
    *,
    tries_per_skill: int = TRIES_PER_SKILL,
    retries_after_backtrack: int = RETRIES_AFTER_BACKTRACK,
    max_executions: int = MAX_EXECUTIONS,
) -> SkeletonSearch:
    """Find parameters for every skill of ``skeleton`` (``SkillCall`` s) from the simulator's
    current state by sampling and snapshot-restored trials.

    A skill gets ``tries_per_skill`` executions from a new start state. When they all fail, the
    search backs up. If the failures were collisions with an object that an earlier skill of the
    skeleton moved (a box placed where the hook must sweep), it jumps back to that skill; otherwise
    to the previous one. A skill revisited this way gets ``retries_after_backtrack`` executions
    before the search backs up further, which keeps the search from growing exponentially."""
    from t2m_core.domain.primitives import get_primitive

    count = len(skeleton)
    result = SkeletonSearch(tries=[0] * count)
    snapshots = [simulator.get_state()]
    budget = [tries_per_skill] * count
    visit_tries = [0] * count
    blamed: list[dict[str, int]] = [{} for _ in range(count)]
    index = 0
    while 0 <= index < count and result.executions < max_executions:
        if visit_tries[index] >= budget[index]:
            target = _backjump_target(skeleton, index, blamed[index])
            for undone in range(target, index + 1):
                visit_tries[undone], budget[undone], blamed[undone] = 0, tries_per_skill, {}
            del snapshots[target + 1 :]
            del result.actions[target:]
            index = target
            if index < 0:
                break
            budget[index] = retries_after_backtrack
            continue
        call = skeleton[index]
        primitive = get_primitive(call.name)
        simulator.set_state(snapshots[index])
        state = simulator.geometric_state()
        first = result.tries[index] == 0
        action = (primitive.heuristic_action if first else primitive.exploration_action)(state, call.args, rng)
        visit_tries[index] += 1
        result.tries[index] += 1
        result.executions += 1
        outcome = simulator.execute(call.name, call.args, action)
        if outcome.success:
            result.actions.append(np.asarray(action, dtype=np.float64))
            snapshots.append(simulator.get_state())
            visit_tries[index] = 0
            index += 1
        else:
            result.failures[outcome.failure] = result.failures.get(outcome.failure, 0) + 1
            for contact in outcome.contacts:
                blamed[index][contact.body_b] = blamed[index].get(contact.body_b, 0) + 1
    result.found = index == count
    return result


def _backjump_target(skeleton: Sequence[Any], index: int, blamed: dict[str, int]) -> int:
    """The skill to sample again after skill ``index`` exhausted its tries: the latest earlier skill
    that moved the object the failures collided with most, else the previous skill (−1: none)."""
    if blamed:
        culprit = max(blamed, key=blamed.get)
        for earlier in range(index - 1, -1, -1):
            call = skeleton[earlier]
            if call.name != "pick" and call.args and call.args[0] == culprit:
                return earlier
    return index - 1
