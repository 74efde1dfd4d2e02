"""Skill-data chunks: determinism, balancing, the invalid split (docs/guide/skills.md#data-generation)."""

from __future__ import annotations

import numpy as np
import pytest

from t2m_core.data.chunks import ChunkSpec, DataGenerationError, generate_chunk
from t2m_core.data.records import INVALID_GROUNDING, OBJECT_VOCABULARY
from t2m_core.data.scenes import HOOK_MASS, draw_grounding, symbolic_states
from t2m_core.domain.observation import normalize
from tests.core.plugin_doubles import ScriptedSimulator


def _same(a, b) -> None:
    for name, column in a.columns().items():
        np.testing.assert_array_equal(column, b.columns()[name], err_msg=name)


@pytest.mark.slow
def test_a_chunk_is_the_same_in_a_fresh_simulator_and_after_other_work() -> None:
    from t2m_core.registry import get_registry

    spec = ChunkSpec("pick", "train", 3, 6, base_seed=11)
    first = get_registry().create("simulator", "mujoco")
    fresh, _ = generate_chunk(spec, first)
    busy = get_registry().create("simulator", "mujoco")
    generate_chunk(ChunkSpec("place", "train", 0, 3, base_seed=5), busy)  # other scenes first
    again, _ = generate_chunk(spec, busy)
    _same(fresh, again)
    other, _ = generate_chunk(ChunkSpec("pick", "train", 4, 6, base_seed=11), busy)
    assert not np.array_equal(other.scene_seed, fresh.scene_seed), "chunks of a split must draw different scenes"


def test_balancing_keeps_at_least_40_percent_successes_when_successes_are_rare() -> None:
    simulator = ScriptedSimulator(lambda action: action[0] > 0.9)  # about 5 % of uniform draws
    transitions, stats = generate_chunk(ChunkSpec("pick", "train", 0, 20, sampler="uniform"), simulator)
    assert len(transitions) == 20
    assert transitions.success.sum() == 8  # ceil(0.4 * 20): failures stop being kept at 12
    assert (transitions.action[transitions.success][:, 0] > 0.9).all()
    assert stats.discarded_failures == simulator.executions - 20 > 0


def test_balancing_keeps_every_success_when_they_are_common() -> None:
    simulator = ScriptedSimulator(lambda action: action[0] > -0.8)  # about 90 %
    transitions, stats = generate_chunk(ChunkSpec("pick", "train", 0, 30, sampler="uniform"), simulator)
    assert stats.discarded_failures == 0
    assert transitions.success.sum() == int((transitions.action[:, 0] > -0.8).sum())


def test_a_simulator_that_never_succeeds_stops_with_a_clear_error() -> None:
    simulator = ScriptedSimulator(lambda action: False)
    with pytest.raises(DataGenerationError, match="draws for"):
        generate_chunk(ChunkSpec("pick", "train", 0, 1, sampler="uniform"), simulator)


def _independently_invalid(skill: str, facts: set[str], arguments: tuple[str, ...]) -> bool:
    """The symbolic validity rule written out again, without the domain's code."""
    held = [f[len("inhand(") : -1] for f in facts if f.startswith("inhand(")]
    box = lambda name: name.endswith("_box")  # noqa: E731
    if skill == "pick":
        (a,) = arguments
        supported = f"on({a}, table)" in facts or f"on({a}, rack)" in facts
        return not (a not in ("table", "rack") and not held and supported)
    if skill == "place":
        a, b = arguments
        return not (a in held and b in ("table", "rack"))
    a, tool = arguments[:2]
    valid = box(a) and tool == "hook" and tool in held and f"on({a}, table)" in facts
    if skill == "push":
        valid = valid and arguments[2] == "rack" and f"under({a}, rack)" not in facts and "beyondworkspace(rack)" in facts
    return not valid


@pytest.mark.parametrize("skill", ["pick", "place", "pull", "push"])
def test_the_invalid_split_holds_symbolically_invalid_calls_with_uniform_actions(skill: str) -> None:
    transitions, _ = generate_chunk(ChunkSpec(skill, "invalid", 0, 40))
    states = symbolic_states()
    for row in range(len(transitions)):
        facts = {str(p) for p in states[transitions.symbolic_state[row]].propositions}
        arguments = transitions.argument_names(row)
        assert _independently_invalid(skill, facts, arguments), f"{skill}{arguments} is valid in {sorted(facts)}"
    assert (transitions.reward == 0).all()
    assert set(transitions.failure_names()) == {INVALID_GROUNDING}
    np.testing.assert_array_equal(transitions.observation, transitions.next_observation)
    assert np.abs(transitions.action).max() <= 1 and transitions.action.std() > 0.4  # uniform in [-1, 1]


def test_rows_record_the_argument_first_order_of_the_call() -> None:
    transitions, _ = generate_chunk(ChunkSpec("place", "invalid", 1, 10))
    for row in range(len(transitions)):
        names = transitions.object_names(row)
        arguments = transitions.argument_names(row)
        order = transitions.row_order[row]
        for position, argument in enumerate(arguments, start=1):
            assert order[position] == 1 + names.index(argument)
        start, stop = transitions.shuffle_range[row]
        assert (start, stop) == (1 + len(arguments), 1 + len(names))
        # the argument's observation row is where the order says: its normalised x is in range
        assert -0.5 <= normalize(transitions.observation[row, order[1]])[0] <= 0.5


def test_valid_pick_and_place_draws_put_half_their_mass_on_the_hook() -> None:
    rng = np.random.default_rng(0)
    for skill in ("pick", "place"):
        on_hook = np.mean([draw_grounding(skill, True, rng)[1].args[0] == "hook" for _ in range(2000)])
        assert abs(on_hook - HOOK_MASS) < 0.04, (skill, on_hook)


def test_unknown_names_are_rejected_with_the_choices() -> None:
    with pytest.raises(DataGenerationError, match="use one of: pick, place, pull, push"):
        ChunkSpec("wipe", "train", 0, 5)
    with pytest.raises(DataGenerationError, match="train, validation, invalid"):
        ChunkSpec("pick", "test", 0, 5)
    assert "table" in OBJECT_VOCABULARY


def test_the_obstructed_sampler_is_refused_for_skills_without_a_sweep() -> None:
    for skill in ("pick", "place"):
        with pytest.raises(DataGenerationError, match="pull or push"):
            ChunkSpec(skill, "train", 0, 5, sampler="obstructed")
    assert ChunkSpec("push", "train", 0, 5, sampler="obstructed").header()["sampler"] == "obstructed"


class _CountingResets(ScriptedSimulator):
    """The scripted simulator, counting resets."""

    def __init__(self, success) -> None:
        super().__init__(success)
        self.resets = 0

    def reset(self, task, *, seed):
        self.resets += 1
        return super().reset(task, seed=seed)


def test_several_actions_per_scene_share_its_reset_and_keep_the_balancing() -> None:
    simulator = _CountingResets(lambda action: action[0] > 0.0)
    transitions, stats = generate_chunk(ChunkSpec("pick", "train", 0, 40, sampler="uniform", actions_per_scene=4), simulator)
    assert len(transitions) == 40 and transitions.success.sum() >= 16
    assert simulator.executions == stats.draws and simulator.resets == -(-simulator.executions // 4)
    # consecutive rows of one scene: the same scene seed and observation, other actions
    seeds = transitions.scene_seed
    runs = np.split(seeds, np.flatnonzero(np.diff(seeds)) + 1)
    assert max(len(run) for run in runs) == 4 and len(runs) < 40
    first = len(runs[0])
    assert first > 1
    np.testing.assert_array_equal(transitions.observation[0], transitions.observation[first - 1])
    assert not np.array_equal(transitions.action[0], transitions.action[1])


def test_one_action_per_scene_is_the_default_and_leaves_the_header_unchanged() -> None:
    assert "actions_per_scene" not in ChunkSpec("pick", "train", 0, 5).header()
    assert ChunkSpec("pick", "train", 0, 5, actions_per_scene=3).header()["actions_per_scene"] == 3
    assert "actions_per_scene" not in ChunkSpec("pick", "invalid", 0, 5, actions_per_scene=3).header()
    with pytest.raises(DataGenerationError, match="actions per scene"):
        ChunkSpec("pick", "train", 0, 5, actions_per_scene=0)


@pytest.mark.slow
def test_each_action_of_a_scene_runs_from_the_exact_reset_state() -> None:
    """A later action of a scene gives what it gives after a fresh reset of that scene (to float32
    rounding: contact solver warm starts differ in the last bits)."""
    from t2m_core.registry import get_registry

    class Recording:
        def __init__(self, simulator) -> None:
            self.simulator, self.resets = simulator, []

        def reset(self, task, *, seed):
            result = self.simulator.reset(task, seed=seed)
            self.resets.append((task, seed, result.accepted_seed))
            return result

        def __getattr__(self, name):
            return getattr(self.simulator, name)

    simulator = Recording(get_registry().create("simulator", "mujoco"))
    transitions, _ = generate_chunk(ChunkSpec("pick", "train", 0, 6, actions_per_scene=3), simulator)
    # a scene whose first action succeeded (the box was lifted) and that has later actions
    scenes = [(task, seed, np.flatnonzero(transitions.scene_seed == accepted)) for task, seed, accepted in simulator.resets]
    task, seed, rows = next((t, s, r) for t, s, r in scenes if len(r) > 1 and transitions.success[r[0]])
    row = int(rows[-1])
    simulator.reset(task, seed=seed)
    result = simulator.execute("pick", task.call.args, transitions.action[row])
    np.testing.assert_allclose(np.asarray(result.observation, dtype=np.float32), transitions.next_observation[row], atol=1e-5)
    assert bool(result.success) == bool(transitions.success[row])


def test_evaluation_scenes_hold_the_single_skill_scenes_a_policy_is_reported_in() -> None:
    spec = ChunkSpec("pick", "train", 0, 12, sampler="uniform", actions_per_scene=2, scenes="evaluation")
    transitions, _ = generate_chunk(spec, ScriptedSimulator(True))
    assert spec.header()["scenes"] == "evaluation" and not spec.rollouts
    for row in range(len(transitions)):
        names, (box,) = transitions.object_names(row), transitions.argument_names(row)
        # evaluation_scenes: the table, the rack, the hook and one box, which is picked
        assert sorted(names) == sorted(("table", "rack", "hook", box)) and box.endswith("_box")
    assert len(set(transitions.scene_seed.tolist())) == 6
    data, _ = generate_chunk(ChunkSpec("pick", "train", 0, 12, sampler="uniform", actions_per_scene=2), ScriptedSimulator(True))
    assert any(len(data.object_names(row)) != 4 for row in range(len(data)))  # the data scenes add distractors
    for split, skeleton in (("invalid", None), ("train", "pick(hook)")):
        with pytest.raises(DataGenerationError, match="--scenes evaluation"):
            ChunkSpec("pick", split, 0, 5, scenes="evaluation", skeleton=skeleton)
