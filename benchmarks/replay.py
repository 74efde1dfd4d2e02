"""Replay a run record's executed skills in the simulator its ``config.yaml`` names, from its scene seed.

The benchmarks that judge recorded steps again (``replan_variance.py``, ``execution_values.py
--checkpoints``) start here. The simulator is deterministic across resets and processes, so the
recorded actions reproduce the recorded outcomes; a replay that does not is refused rather than
judged (docs/guide/run-records.md).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from t2m_core.errors import T2MError


@dataclass
class Replay:
    """A run record reset in its simulator.

    Attributes:
        run: the run directory.
        result: its ``result.json``.
        config: its resolved ``config.yaml``.
        simulator: the recorded simulator, reset to the recorded scene.
        names: the scene's objects in observation-row order.
    """

    run: Path
    result: dict[str, Any]
    config: Any
    simulator: Any
    names: tuple[str, ...]

    def steps(self) -> Iterator[tuple[int, Any, dict[str, Any]]]:
        """``(index, call, record)`` of each executed skill, yielded *before* it runs (the simulator
        then holds the state the run planned it from); the step is executed when the iteration
        resumes. A caller may stop early.

        Raises:
            T2MError: a replayed step ended otherwise than recorded.
        """
        from t2m_core.domain.skills import parse_skill_call

        for index, record in enumerate(self.result.get("executed") or []):
            call = parse_skill_call(record["skill"], self.names)
            yield index, call, record
            outcome = self.simulator.execute(call.name, call.args, np.asarray(record["action"], dtype=np.float64))
            if bool(outcome.success) != bool(record["success"]):
                raise T2MError(f"{self.run}: replaying {record['skill']} {'succeeded' if outcome.success else f'failed ({outcome.failure})'}; "
                               f"the run's {'succeeded' if record['success'] else 'failed'}",
                               "the simulator or its options changed since the run; replay it with the version that made it")


def start_replay(run: Path) -> Replay:
    """Build ``run``'s simulator from its ``config.yaml`` and reset it to the recorded scene.

    Raises:
        T2MError: no ``result.json``, or the reset accepted another seed than the run's.
    """
    from t2m_core.components import build_component
    from t2m_core.config.resolve import resolve_config
    from t2m_core.registry import get_registry
    from t2m_core.run_records import read_result
    from t2m_core.tasks import load_task

    result = read_result(run)
    if result is None:
        raise T2MError(f"{run} holds no result.json", "give a finished run directory")
    config = resolve_config([run / "config.yaml"], registry=get_registry())
    simulator = build_component(config, "simulator")
    reset = simulator.reset(load_task(config.task), seed=result["seed"])
    if result.get("accepted_seed") is not None and reset.accepted_seed != result["accepted_seed"]:
        raise T2MError(f"{run}: the reset accepted seed {reset.accepted_seed}, the run {result['accepted_seed']}",
                       "the scene sampler changed since the run; replay it with the version that made it")
    return Replay(run, result, config, simulator, reset.state.object_names)
