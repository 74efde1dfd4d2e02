"""The STAP feasibility planners on problems whose answer is known (docs/guide/feasibility.md)."""

from __future__ import annotations

import numpy as np
import pytest

from t2m_core.domain.skills import SkillCall
from t2m_core.testing import check_feasibility_planner
from t2m_stap.options import CEMOptions, PolicyOptions, RandomCEMOptions, ShootingOptions
from t2m_stap.planners import CrossEntropyMethod, PolicyRollout, Shooting
from tests.plugins.t2m_stap.toy_skills import ToySkill

OBJECTS = ("table", "rack", "red_box", "blue_box")
OBSERVATION = np.zeros((8, 12), np.float32)
OBSERVATION[2, :3] = (0.7, 0.0, 0.0)  # rows: 0 end effector, 1 table (zeros), 2 rack, 3 red_box, 4 blue_box
OBSERVATION[3, :3] = (0.5, 0.1, 0.03)
OBSERVATION[4, :3] = (0.4, -0.2, 0.05)
PICK = SkillCall("pick", ("red_box",))
PLACE = SkillCall("place", ("red_box", "rack"))

PLANNERS = {
    "policy-cem": lambda: CrossEntropyMethod(CEMOptions(population=400, seed=1), "policy"),
    "random-cem": lambda: CrossEntropyMethod(RandomCEMOptions(population=100, seed=1), "random"),
    "policy-shooting": lambda: Shooting(ShootingOptions(population=500, seed=1), "policy"),
    "random-shooting": lambda: Shooting(ShootingOptions(population=500, seed=1), "random"),
    "policy": lambda: PolicyRollout(),
}


@pytest.mark.parametrize("name", sorted(PLANNERS))
def test_every_planner_conforms(name: str) -> None:
    skills = {"pick": ToySkill("pick"), "place": ToySkill("place", chained=True)}
    check_feasibility_planner(PLANNERS[name](), OBSERVATION, [PICK, PLACE], skills, OBJECTS)


def test_cem_finds_the_best_action_that_the_policy_misses() -> None:
    skills = {"pick": ToySkill("pick", target=(0.6, -0.4, 0.2, 0.0))}
    policy = PolicyRollout().plan(OBSERVATION, [PICK], skills, OBJECTS)
    cem = CrossEntropyMethod(CEMOptions(population=2000, veto=[])).plan(OBSERVATION, [PICK], skills, OBJECTS)  # the toy geometry aside
    assert policy.p_success < 0.05
    np.testing.assert_allclose(cem.actions[0], (0.6, -0.4, 0.2, 0.0), atol=0.05)
    assert cem.p_success > 0.95
    assert cem.values[0] == pytest.approx(0.98 * np.exp(-np.sum((cem.actions[0] - (0.6, -0.4, 0.2, 0.0)) ** 2) / 0.1), rel=1e-4)


def test_cem_resolves_a_dependency_across_steps_through_the_dynamics() -> None:
    # step 2 succeeds only if its first action component is twice what step 1 left in the state,
    # and step 1 is indifferent to its own first component: only a joint optimisation gets both right
    first = ToySkill("pick", target=(0.0, -0.4, 0.2, 0.0))
    first.q_values = lambda states, actions: (  # noqa: E731 - step 1 ignores its first component
        ToySkill.q_values(first, states, actions * __import__("torch").tensor([0.0, 1.0, 1.0, 1.0]))
    )
    skills = {"pick": first, "place": ToySkill("place", policy_action=(0.9, -0.4, 0.2, 0.0), chained=True)}
    result = CrossEntropyMethod(CEMOptions(population=3000)).plan(OBSERVATION, [PICK, PLACE], skills, OBJECTS)
    assert result.p_success > 0.8
    # the predicted state carries step 1's choice, and step 2's action matches it
    moved_x_normalised = (result.states[1, 3, 0] - 0.3) / 1.2
    assert result.actions[1, 0] == pytest.approx(2 * moved_x_normalised, abs=0.1)
    assert result.actions[1, 0] == pytest.approx(0.8 * result.actions[0, 0], abs=0.1)  # 2 × (0.4 × a₀)
    greedy = PolicyRollout().plan(OBSERVATION, [PICK, PLACE], skills, OBJECTS)
    assert greedy.p_success < 0.1  # the policies alone do not coordinate the two steps


def test_the_returned_plan_carries_its_rollout() -> None:
    skills = {"pick": ToySkill("pick"), "place": ToySkill("place", chained=True)}
    result = CrossEntropyMethod(CEMOptions(population=300)).plan(OBSERVATION, [PICK, PLACE], skills, OBJECTS)
    # the dynamics wrote action[0] * 0.4 into the first argument's normalised x: decoded, that is x
    expected_x = result.actions[0, 0] * 0.4 * 1.2 + 0.3
    assert result.states[1, 3, 0] == pytest.approx(expected_x, abs=1e-5)
    np.testing.assert_array_equal(result.states[1, 3, 6:], OBSERVATION[3, 6:])  # static features copied
    assert not result.states[1, 5:].any()  # rows beyond the present objects stay empty
    assert result.q_members.shape == (2, 8) and result.variances.shape == (2,)


def test_an_ood_step_zeroes_the_plan_but_not_the_optimisation_by_default() -> None:
    skills = {"pick": ToySkill("pick", ood_threshold=1e-6)}  # the toy members always disagree a little
    result = CrossEntropyMethod(CEMOptions(population=500, veto=[])).plan(OBSERVATION, [PICK], skills, OBJECTS)
    assert result.ood.all() and result.p_success == 0.0
    assert result.values[0] > 0.9  # the flag was applied after optimising, not inside it


class DetectedSkill(ToySkill):
    """A toy skill with a separate OOD detector: actions whose second component is positive are out of
    distribution (variance 0.25), the others in (0); it counts the pairs it was asked about."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.detected_pairs = 0

    def ood_variance(self, states, actions, q_members):
        self.detected_pairs += len(actions)
        return (actions[:, 1] > 0).float() * 0.25


def test_a_separate_detector_flags_the_returned_plan_and_costs_the_search_nothing() -> None:
    # the best action (0.6, 0.4, ...) is flagged by the detector only: the toy members barely disagree there
    skill = DetectedSkill("pick", target=(0.6, 0.4, 0.2, 0.0), ood_threshold=0.1)
    result = CrossEntropyMethod(CEMOptions(population=500, veto=[])).plan(OBSERVATION, [PICK], {"pick": skill}, OBJECTS)
    assert result.actions[0, 1] > 0 and result.values[0] > 0.9
    assert result.ood.all() and result.p_success == 0.0 and result.variances[0] == pytest.approx(0.25)
    assert skill.detected_pairs == 1  # the returned trajectory alone
    # scored by the masked product, the search avoids what the detector flags
    penalised = DetectedSkill("pick", target=(0.6, 0.4, 0.2, 0.0), ood_threshold=0.1)
    avoided = CrossEntropyMethod(CEMOptions(population=500, veto=[], ood_penalty=True)).plan(OBSERVATION, [PICK], {"pick": penalised}, OBJECTS)
    assert avoided.actions[0, 1] <= 0 and not avoided.ood.any() and avoided.p_success > 0.1
    assert penalised.detected_pairs > 500


def test_the_population_can_scale_with_the_horizon() -> None:
    assert CEMOptions(population=100).samples(3) == 100
    assert CEMOptions(population=100, scale_population_by_horizon=True).samples(3) == 1200


def test_an_unknown_skill_is_named_with_the_library_contents() -> None:
    with pytest.raises(KeyError, match="has no 'push' skill; it has pick"):
        PolicyRollout().plan(OBSERVATION, [SkillCall("push", ("red_box", "hook", "rack"))], {"pick": ToySkill("pick")}, (*OBJECTS, "hook"))


def test_policy_cem_starts_from_given_prefix_actions_and_the_policy_after_them() -> None:
    # one sample, one iteration: the plan is the starting mean itself
    skills = {"pick": ToySkill("pick", target=(0.6, -0.4, 0.2, 0.0)), "place": ToySkill("place", policy_action=(0.1, 0.2, 0.3, 0.4), chained=True)}
    single = CEMOptions(population=1, iterations=1, elites=1)
    given = np.array([[0.6, -0.4, 0.2, 0.0]], np.float32)
    started = CrossEntropyMethod(single).plan(OBSERVATION, [PICK, PLACE], skills, OBJECTS, initial_actions=given)
    np.testing.assert_allclose(started.actions, [[0.6, -0.4, 0.2, 0.0], [0.1, 0.2, 0.3, 0.4]], atol=1e-6)
    assert started.values[0] > 0.95
    unstarted = CrossEntropyMethod(single).plan(OBSERVATION, [PICK, PLACE], skills, OBJECTS)
    np.testing.assert_allclose(unstarted.actions[0], [0.0, 0.0, 0.0, 0.0], atol=1e-6)  # the policy's
    assert unstarted.values[0] < 0.05


def test_a_prefix_start_never_ends_worse_than_the_start_itself() -> None:
    skills = {"pick": ToySkill("pick", target=(0.6, -0.4, 0.2, 0.0)), "place": ToySkill("place", chained=True)}
    given = np.array([[0.6, -0.4, 0.2, 0.0]], np.float32)
    start = CrossEntropyMethod(CEMOptions(population=1, iterations=1, elites=1)).plan(OBSERVATION, [PICK, PLACE], skills, OBJECTS, initial_actions=given)
    searched = CrossEntropyMethod(CEMOptions(population=50, seed=3)).plan(OBSERVATION, [PICK, PLACE], skills, OBJECTS, initial_actions=given)
    assert searched.p_success >= start.p_success


@pytest.mark.parametrize("shape", [(3, 4), (1, 3), (4,)])
def test_prefix_actions_of_the_wrong_shape_are_refused(shape: tuple[int, ...]) -> None:
    skills = {"pick": ToySkill("pick"), "place": ToySkill("place", chained=True)}
    with pytest.raises(ValueError, match=r"initial_actions must be \(T0, 4\) with T0 <= 2"):
        CrossEntropyMethod(CEMOptions(population=10)).plan(OBSERVATION, [PICK, PLACE], skills, OBJECTS, initial_actions=np.zeros(shape))


def test_restarts_keep_the_best_of_several_runs() -> None:
    # eight samples and two iterations rarely reach the target: more runs from the same start find better plans
    skills = {"pick": ToySkill("pick", target=(0.6, -0.4, 0.2, 0.0)), "place": ToySkill("place", chained=True)}

    def plan(seed: int, restarts: int):
        options = CEMOptions(population=8, iterations=2, elites=2, seed=seed, restarts=restarts)
        return CrossEntropyMethod(options).plan(OBSERVATION, [PICK, PLACE], skills, OBJECTS)

    single = [plan(seed, 1) for seed in range(4)]
    several = [plan(seed, 6) for seed in range(4)]
    assert all(s.p_success >= one.p_success for s, one in zip(several, single))  # the first run is the single run
    assert max(s.p_success / one.p_success for s, one in zip(several, single)) > 10
    for result in several:
        assert result.p_success == pytest.approx(float(np.prod(result.values)), rel=1e-5)  # the plan carries its own values
    with pytest.raises(ValueError, match="restarts"):
        CEMOptions(restarts=0)


def test_the_adaptive_spread_narrows_onto_a_long_skeletons_optimum() -> None:
    # six steps, 24 dimensions, 200 samples: a constant sigma = 0.3 keeps scattering every step around
    # the optimum, while the elites' spread shrinks onto it
    skills = {"pick": ToySkill("pick", target=(0.6, -0.4, 0.2, 0.0))}

    def plan(mode: str, seed: int):
        options = CEMOptions(population=200, seed=seed, sigma_mode=mode, veto=[], veto_first=[])  # the toy geometry aside
        return CrossEntropyMethod(options).plan(OBSERVATION, [PICK] * 6, skills, OBJECTS)

    for seed in range(3):
        constant, adaptive = plan("constant", seed), plan("adaptive", seed)
        assert adaptive.p_success > 2 * constant.p_success
        assert adaptive.p_success > 0.3 and constant.p_success < 0.25
        # the optimum is known: every adaptive step lands nearer to it than the constant plan's worst step
        error = lambda plan: np.abs(plan.actions - np.array([0.6, -0.4, 0.2, 0.0])).max(axis=1)  # noqa: E731
        assert error(adaptive).max() < error(constant).max()


def test_policy_cem_adapts_its_spread_by_default_and_random_cem_keeps_the_published_one() -> None:
    # docs/guide/deviations.md#policycem-population-and-spread: both start from the paper's sigma
    assert (CEMOptions().sigma_mode, CEMOptions().sigma) == ("adaptive", 0.3)
    assert (RandomCEMOptions().sigma_mode, RandomCEMOptions().sigma) == ("constant", 1.0)
    assert CEMOptions(sigma_mode="constant").sigma_mode == "constant"
    with pytest.raises(ValueError, match="sigma_mode"):
        CEMOptions(sigma_mode="elites")


def _blocked_pull():
    """A held hook, the blue box at (0.8, 0) and the red box at (0.6, 0.15), beside its way to the
    base; the pull straight at the base with y = 0 sweeps into the red box."""
    from t2m_core.domain.observation import encode_observation
    from tests.domain.test_sweep_screen import PULL, holding_hook, on_table, pull

    state = holding_hook((0.8, 0.0), grasp_x=-0.1, rack=False, red_box=on_table("red_box", 0.6, 0.15))
    through = PULL.to_normalized(pull(-0.3, 0.0))
    return state, encode_observation(state, state.object_names), state.object_names, through


def test_the_veto_moves_the_plan_off_a_pull_into_a_bystander() -> None:
    from tests.domain.test_sweep_screen import PULL, PULL_ARGS

    state, observation, names, through = _blocked_pull()
    skills = {"pull": ToySkill("pull", target=tuple(through), policy_action=tuple(through))}
    call = SkillCall("pull", PULL_ARGS)
    assert PULL.in_the_way(state, PULL_ARGS, PULL.to_physical(through)[None])[0]  # the toy's best action hits the red box
    plain = CrossEntropyMethod(CEMOptions(population=500, veto=[])).plan(observation, [call], skills, names)
    np.testing.assert_allclose(plain.actions[0], through, atol=0.05)
    assert plain.values[0] > 0.95
    vetoed = CrossEntropyMethod(CEMOptions(population=500, veto=["pull"])).plan(observation, [call], skills, names)
    assert not PULL.in_the_way(state, PULL_ARGS, PULL.to_physical(vetoed.actions[0])[None])[0]
    expected = 0.98 * np.exp(-np.sum((vetoed.actions[0] - through) ** 2) / 0.1)  # the toy's value there, not vetoed
    assert 0.05 < vetoed.values[0] < 0.9 and vetoed.values[0] == pytest.approx(expected, rel=1e-4)
    # The policy alone reports its action's value as 0, and a skill without a sweep is left alone.
    assert PolicyRollout(PolicyOptions(veto=["pull"])).plan(observation, [call], skills, names).p_success == 0.0
    assert PolicyRollout().plan(observation, [call], skills, names).p_success > 0.95
    pick = {"pick": ToySkill("pick")}
    a = CrossEntropyMethod(CEMOptions(population=300, veto=["pull", "push", "place"])).plan(OBSERVATION, [PICK], pick, OBJECTS)
    b = CrossEntropyMethod(CEMOptions(population=300, veto=[])).plan(OBSERVATION, [PICK], pick, OBJECTS)
    np.testing.assert_array_equal(a.actions, b.actions)



def test_the_veto_turns_a_grasp_off_the_rack_plate() -> None:
    # The red box stands 1.5 cm from the rack's plate; the toy's best grasp opens the jaw towards it.
    from t2m_core.domain.observation import encode_observation
    from t2m_core.domain.primitives import PRIMITIVES
    from tests.domain.scenes import RACK_IN_WORKSPACE, on_table, scene

    pick = PRIMITIVES["pick"]
    state = scene(rack=RACK_IN_WORKSPACE, red_box=on_table("red_box", 0.5, -0.18))
    names, call = state.object_names, SkillCall("pick", ("red_box",))
    towards = pick.to_normalized(np.zeros(4))
    assert pick.in_the_way(state, call.args, np.zeros((1, 4)))[0]
    skills = {"pick": ToySkill("pick", target=tuple(towards), policy_action=tuple(towards))}
    observation = encode_observation(state, names)
    plain = CrossEntropyMethod(CEMOptions(population=500, veto=[])).plan(observation, [call], skills, names)
    assert pick.in_the_way(state, call.args, pick.to_physical(plain.actions[0])[None])[0]
    vetoed = CrossEntropyMethod(CEMOptions(population=500, veto=["pick"])).plan(observation, [call], skills, names)
    assert not pick.in_the_way(state, call.args, pick.to_physical(vetoed.actions[0])[None])[0]
    assert 0.05 < vetoed.values[0] < plain.values[0]


def test_the_veto_option_takes_the_skills_that_have_a_prediction() -> None:
    from pydantic import ValidationError

    assert CEMOptions().veto == ["pick", "pull"] and CEMOptions(veto=["pick", "pull", "place"]).veto == ["pick", "pull", "place"]
    assert CEMOptions(veto=[]).veto == [] and RandomCEMOptions().veto == [] and PolicyOptions().veto == []  # PolicyCEM's default only
    with pytest.raises(ValidationError, match="pull"):
        CEMOptions(veto=["stop"])  # stop has no prediction of its own


def test_a_veto_entry_names_a_skill_or_a_lifted_call() -> None:
    from pydantic import ValidationError

    assert CEMOptions(veto=["pick", " place( hook,table ) "]).veto == ["pick", "place(hook, table)"]  # normalised
    for entry, problem in (("place(hook)", "takes 2 object kind"), ("place(hook, shelf)", "takes 2 object kind"),
                           ("stop(table)", "names no skill"), ("place(hook, table", "expected ',' or '\\)'")):
        with pytest.raises(ValidationError, match=problem):
            CEMOptions(veto=[entry])


def test_a_lifted_veto_entry_vetoes_only_its_calls() -> None:
    from t2m_stap.rollout import prepare_steps

    calls = [SkillCall("place", ("hook", "table")), SkillCall("place", ("red_box", "table")), SkillCall("place", ("red_box", "rack"))]
    skills = {"place": ToySkill("place")}
    names = ("table", "rack", "hook", "red_box")
    by_entry = {
        "place(hook, table)": [True, False, False],
        "place(box, table)": [False, True, False],
        "place": [True, True, True],
        "pick": [False, False, False],
    }
    for entry, expected in by_entry.items():
        steps = prepare_steps(calls, skills, names, vetoed=frozenset(CEMOptions(veto=[entry]).veto))
        assert [step.veto is not None for step in steps] == expected, entry


def test_veto_first_vetoes_its_entries_at_the_first_call_only() -> None:
    from pydantic import ValidationError

    from t2m_stap.rollout import prepare_steps

    calls = [SkillCall("place", ("hook", "table")), SkillCall("pick", ("red_box",)), SkillCall("place", ("hook", "table"))]
    skills = {"place": ToySkill("place"), "pick": ToySkill("pick")}
    names = ("table", "rack", "hook", "red_box")
    options = CEMOptions(veto=["pick"], veto_first=["place(hook, table)"])
    steps = prepare_steps(calls, skills, names, vetoed=frozenset(options.veto), vetoed_first=frozenset(options.veto_first))
    assert [step.veto is not None for step in steps] == [True, True, False]  # the later hook placement is not vetoed
    steps = prepare_steps(calls[1:], skills, names, vetoed=frozenset(), vetoed_first=frozenset(["place(hook, table)"]))
    assert [step.veto is not None for step in steps] == [False, False]  # first only: pick is not the entry's call
    assert CEMOptions().veto_first == ["place(hook, table)"]
    assert PolicyOptions().veto_first == [] and RandomCEMOptions().veto_first == []
    with pytest.raises(ValidationError, match="takes 2 object kind"):
        CEMOptions(veto_first=["place(hook)"])


def test_veto_first_turns_the_first_grasp_off_the_rack_plate() -> None:
    # The scene of test_the_veto_turns_a_grasp_off_the_rack_plate, vetoed through veto_first alone.
    from t2m_core.domain.observation import encode_observation
    from t2m_core.domain.primitives import PRIMITIVES
    from tests.domain.scenes import RACK_IN_WORKSPACE, on_table, scene

    pick = PRIMITIVES["pick"]
    state = scene(rack=RACK_IN_WORKSPACE, red_box=on_table("red_box", 0.5, -0.18))
    names, call = state.object_names, SkillCall("pick", ("red_box",))
    towards = pick.to_normalized(np.zeros(4))
    skills = {"pick": ToySkill("pick", target=tuple(towards), policy_action=tuple(towards))}
    observation = encode_observation(state, names)
    first = CrossEntropyMethod(CEMOptions(population=500, veto=[], veto_first=["pick"])).plan(observation, [call], skills, names)
    assert not pick.in_the_way(state, call.args, pick.to_physical(first.actions[0])[None])[0]


def test_clip_grasps_keeps_every_sampled_grasp_of_a_box_on_it() -> None:
    # The toy's best grasp of the red box (50 mm square) lies 8 cm beside it (normalised x 0.4 of ±0.2 m).
    from t2m_stap.planners import action_bounds

    skills = {"pick": ToySkill("pick", target=(0.4, 0.0, 0.0, 0.0), policy_action=(0.4, 0.0, 0.0, 0.0))}
    plain = CrossEntropyMethod(CEMOptions(population=300, veto=[])).plan(OBSERVATION, [PICK], skills, OBJECTS)
    assert plain.actions[0, 0] == pytest.approx(0.4, abs=0.1)
    clipped = CrossEntropyMethod(CEMOptions(population=300, veto=[], clip_grasps=True)).plan(OBSERVATION, [PICK], skills, OBJECTS)
    assert clipped.actions[0, 0] == pytest.approx(0.015 / 0.2, abs=1e-6)  # 1 cm inside the box's face (25 mm), normalised
    low, high = action_bounds([type("S", (), {"call": PICK})(), type("S", (), {"call": SkillCall("pick", ("hook",))})()], clip_grasps=True)
    np.testing.assert_allclose(high.numpy(), [[0.075, 0.15, 1.0, 1.0], [1.0, 1.0, 1.0, 1.0]], rtol=1e-6)  # 15 mm of ±0.2 m and ±0.1 m
    np.testing.assert_allclose(low.numpy(), -high.numpy())
