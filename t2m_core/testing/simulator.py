"""Conformance checks for :class:`t2m_core.protocols.Simulator` implementations.

Every backend must pass them; a third-party backend runs them in its own tests::

    from t2m_core.testing import check_simulator

    def test_my_backend_conforms():
        check_simulator(lambda: MySimulator(MyOptions()), task_ids=("task0",), seeds=(0, 1))

Checked, per task and seed: seeded resets are deterministic (same accepted seed, same state,
bit-identical observations); the observation is ``(8, 12) float32`` with row 0 the end effector and
rows 1..N the task's objects in order, each matching the state; ``get_state``/``set_state``
restores a snapshot exactly (re-executing the same primitive from it, or straight after a fresh
reset, gives the same result and state; a reset does not depend on earlier simulation); primitive
results use the failure vocabulary with ``truncated`` matching the reason; and every reported
success is confirmed by facts the backend did not compute: the reported poses, judged by the plain
geometry of :mod:`t2m_core.testing.success_facts` (a placed object rests on its target, a picked one
is held and lifted...). Besides the heuristic and a uniform action for the first skill of each
task's reference skeleton, the first ``skeleton_steps`` skills are walked with sampled parameters
(:func:`t2m_core.skeleton_search.search_skeleton`) so that Place is judged too.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

DEFAULT_TASKS = ("task0", "task3")
DEFAULT_SEEDS = (0, 1)
SKELETON_STEPS = 2
"""Skills of each reference skeleton walked with sampled parameters (pick, then place)."""
SKELETON_TRIES = 10
"""Executions per skill of that walk before it gives up (Place's heuristic succeeds about half the time)."""


def _assert_states_equal(a: Any, b: Any, what: str, atol: float = 0.0) -> None:
    assert tuple(a.objects) == tuple(b.objects), f"{what}: object order differs: {tuple(a.objects)} != {tuple(b.objects)}"
    for name in a.objects:
        np.testing.assert_allclose(a.objects[name].position, b.objects[name].position, atol=atol, rtol=0,
                                   err_msg=f"{what}: position of {name}")
        np.testing.assert_allclose(a.objects[name].quaternion, b.objects[name].quaternion, atol=atol, rtol=0,
                                   err_msg=f"{what}: orientation of {name}")
    np.testing.assert_allclose(a.ee_position, b.ee_position, atol=atol, rtol=0, err_msg=f"{what}: EE position")
    assert a.held == b.held, f"{what}: held object {a.held!r} != {b.held!r}"


def check_observation(observation: np.ndarray, state: Any, object_names: Sequence[str]) -> None:
    """The ``(8, 12) float32`` layout (docs/guide/world.md#observation-encoding) agrees with ``state``."""
    from t2m_core.domain.observation import encode_observation

    assert isinstance(observation, np.ndarray), f"observation must be a numpy array, got {type(observation)}"
    assert observation.shape == (8, 12) and observation.dtype == np.float32, (
        f"observation must be (8, 12) float32, got {observation.shape} {observation.dtype}"
    )
    np.testing.assert_allclose(observation, encode_observation(state, object_names), atol=1e-6,
                               err_msg="observation does not encode the reported state")
    np.testing.assert_allclose(observation[0, :3], state.ee_position, atol=1e-6, err_msg="row 0 must be the EE")
    for row, name in enumerate(object_names, start=1):
        if name != "table":  # the table's row is all zeros
            np.testing.assert_allclose(observation[row, :3], state.objects[name].position, atol=1e-6,
                                       err_msg=f"row {row} must be {name}'s position")
    assert not observation[len(object_names) + 1 :].any(), "rows after the present objects must be zero"


def check_result(result: Any, primitive: str, arguments: Sequence[str], start_state: Any) -> None:
    """A :class:`~t2m_core.protocols.PrimitiveResult` uses the domain's failure vocabulary, and a
    reported success is confirmed by the reported poses (:mod:`t2m_core.testing.success_facts`)."""
    from t2m_core.domain.primitives import FAILURES
    from t2m_core.testing.success_facts import success_problems

    assert result.success == (result.failure is None), f"{primitive}: success={result.success} with failure={result.failure!r}"
    if result.failure is not None:
        assert result.failure in FAILURES, f"{primitive}: failure {result.failure!r} is not in the domain vocabulary"
        assert result.truncated == FAILURES[result.failure][0], f"{primitive}: truncated disagrees with {result.failure!r}"
    else:
        assert not result.truncated, f"{primitive}: a success cannot be truncated"
        problems = success_problems(primitive, start_state, result.state, arguments)
        assert not problems, f"{primitive}{tuple(arguments)}: reported success, but {'; '.join(problems)}"
    check_observation(result.observation, result.state, tuple(result.state.objects))


class _CheckedExecutions:
    """A simulator whose every execution is checked with :func:`check_result` and counted."""

    def __init__(self, simulator: Any, successes: dict[str, int]) -> None:
        self.simulator = simulator
        self.successes = successes
        self.executions = 0

    def get_state(self) -> Any:
        return self.simulator.get_state()

    def set_state(self, snapshot: Any) -> None:
        self.simulator.set_state(snapshot)

    def geometric_state(self) -> Any:
        return self.simulator.geometric_state()

    def execute(self, primitive: str, arguments: Sequence[str], action: np.ndarray) -> Any:
        start = self.simulator.geometric_state()
        result = self.simulator.execute(primitive, arguments, action)
        check_result(result, primitive, arguments, start)
        self.executions += 1
        self.successes[primitive] = self.successes.get(primitive, 0) + int(result.success)
        return result


def check_simulator(
    make_simulator: Callable[[], Any],
    task_ids: Sequence[str] = DEFAULT_TASKS,
    seeds: Sequence[int] = DEFAULT_SEEDS,
    skeleton_steps: int = SKELETON_STEPS,
) -> dict[str, Any]:
    """Run every conformance check on simulators built by ``make_simulator``; raises
    ``AssertionError`` naming the first violation.

    Returns a small report: ``executions`` and ``successes`` per primitive of the first-skill
    checks, ``skeleton_executions`` and ``skeleton_successes`` of the skeleton walks."""
    from t2m_core.domain.primitives import get_primitive
    from t2m_core.protocols import Simulator
    from t2m_core.skeleton_search import search_skeleton
    from t2m_core.tasks import load_task

    first, second = make_simulator(), make_simulator()
    report: dict[str, Any] = {"executions": 0, "successes": {}, "skeleton_executions": 0, "skeleton_successes": {}}
    try:
        assert isinstance(first, Simulator), f"{type(first).__name__} does not implement the Simulator protocol"
        for task_id in task_ids:
            task = load_task(task_id)
            for seed in seeds:
                reset_a, reset_b = first.reset(task, seed=seed), second.reset(task, seed=seed)
                assert reset_a.accepted_seed == reset_b.accepted_seed, f"{task_id} seed {seed}: accepted seeds differ"
                assert reset_a.accepted_seed >= seed and reset_a.rejections >= 0
                _assert_states_equal(reset_a.state, reset_b.state, f"{task_id} seed {seed} reset determinism")
                np.testing.assert_array_equal(reset_a.observation, reset_b.observation,
                                              err_msg=f"{task_id} seed {seed}: reset observations differ")
                check_observation(reset_a.observation, reset_a.state, task.objects)
                check_observation(first.observation(), first.geometric_state(), task.objects)

                call = task.reference_skeleton[0]
                primitive = get_primitive(call.name)
                rng = np.random.default_rng(seed)
                snapshot = first.get_state()
                start = first.geometric_state()
                results = []
                for action in (primitive.heuristic_action(start, call.args, rng), rng.uniform(-1, 1, 4)):
                    first.set_state(snapshot)
                    _assert_states_equal(first.geometric_state(), start, f"{task_id} seed {seed}: set_state")
                    result = first.execute(call.name, call.args, action)
                    check_result(result, call.name, call.args, start)
                    results.append((action, result))
                    report["executions"] += 1
                    name = call.name
                    report["successes"][name] = report["successes"].get(name, 0) + int(result.success)
                # the same action from the same snapshot reproduces the same outcome and state
                action, result = results[0]
                first.set_state(snapshot)
                again = first.execute(call.name, call.args, action)
                assert (again.success, again.failure) == (result.success, result.failure), (
                    f"{task_id} seed {seed}: {call} from a restored snapshot gave {again.failure!r}, first {result.failure!r}"
                )
                _assert_states_equal(again.state, result.state, f"{task_id} seed {seed}: replay from snapshot", atol=1e-9)
                # straight from a reset (no restore in between) gives the same result too, and a
                # reset does not depend on what was simulated before it
                again_reset = first.reset(task, seed=seed)
                np.testing.assert_array_equal(again_reset.observation, reset_b.observation,
                                              err_msg=f"{task_id} seed {seed}: reset depends on earlier simulation")
                direct = first.execute(call.name, call.args, action)
                assert (direct.success, direct.failure) == (result.success, result.failure), (
                    f"{task_id} seed {seed}: {call} straight after reset gave {direct.failure!r}, from a snapshot {result.failure!r}"
                )
                _assert_states_equal(direct.state, result.state, f"{task_id} seed {seed}: run without restore", atol=1e-9)
                # the first skills of the skeleton with sampled parameters: every success is judged
                first.reset(task, seed=seed)
                checked = _CheckedExecutions(first, report["skeleton_successes"])
                search_skeleton(checked, task.reference_skeleton[:skeleton_steps], np.random.default_rng(seed),
                                tries_per_skill=SKELETON_TRIES, retries_after_backtrack=1,
                                max_executions=SKELETON_TRIES * skeleton_steps)
                report["skeleton_executions"] += checked.executions
        successes = sum(report["successes"].values()) + sum(report["skeleton_successes"].values())
        assert successes > 0, (
            f"no primitive succeeded in {report['executions'] + report['skeleton_executions']} executions: "
            "no success could be confirmed (is the backend executing the motions?)"
        )
    finally:
        first.close()
        second.close()
    return report
