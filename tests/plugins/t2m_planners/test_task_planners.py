"""The lookahead task planners' decisions on problems whose answer the test knows
(docs/guide/planners.md)."""

from __future__ import annotations

import numpy as np
import pytest

from t2m_core.domain.goals import parse_goal
from t2m_core.domain.observation import encode_observation
from t2m_core.domain.sampling import sample_initial_state
from t2m_core.domain.skills import parse_skill_call
from t2m_core.language.scene_description import describe_state
from t2m_core.language.session import LanguageSession
from t2m_core.protocols import PlanningContext
from t2m_core.testing import check_task_planner
from t2m_planners.lookahead import LookaheadPlanner, continuations
from t2m_planners.options import HybridOptions, LookaheadOptions
from tests.plugins.t2m_planners.planner_doubles import RuleModel, SymbolicFeasibility

OBJECTS = ("table", "rack", "red_box", "blue_box")
STATE = ("aligned(rack)", "poslimit(rack)", "inworkspace(rack)", "on(rack, table)", "on(red_box, table)", "on(blue_box, table)",
         "free(red_box)", "free(blue_box)", "inworkspace(red_box)", "inworkspace(blue_box)")
GOAL = parse_goal("[['on(red_box, rack)']]")
SOLUTION = "['pick(red_box)', 'place(red_box, rack)']"


def context(model: RuleModel, feasibility: SymbolicFeasibility, events: list | None = None) -> PlanningContext:
    state = sample_initial_state(OBJECTS, STATE, 0).state
    session = LanguageSession(model, describe_state("put the red box on the rack", state, OBJECTS), constrained=False, grounded=False)
    return PlanningContext("put the red box on the rack", GOAL, session, {}, feasibility, OBJECTS,
                           encode_observation(state, OBJECTS), on_event=events.append if events is not None else None)


def test_shooting_truncates_at_the_first_goal_state_and_takes_the_most_feasible() -> None:
    model = RuleModel(sequences=f"[{SOLUTION[:-1]}, 'pick(blue_box)'], ['pick(red_box)', 'place(red_box, table)']]")
    feasibility = SymbolicFeasibility()
    result = check_task_planner(LookaheadPlanner(LookaheadOptions(), "shooting"), context(model, feasibility))
    assert result.found and [str(c) for c in result.skeleton] == ["pick(red_box)", "place(red_box, rack)"]  # pick(blue_box) cut
    assert result.plan.values.shape == (2,) and result.plan.p_success == pytest.approx(0.81)
    assert result.llm_calls == 1 and result.stap_calls == 2


def test_a_goal_reaching_sequence_with_a_step_below_tau_or_out_of_distribution_is_rejected() -> None:
    for feasibility in (SymbolicFeasibility(values={"place(red_box, rack)": 0.15}), SymbolicFeasibility(ood=["pick(red_box)"])):
        result = LookaheadPlanner(LookaheadOptions(), "shooting").plan(context(RuleModel(sequences=f"[{SOLUTION}]"), feasibility))
        assert not result.found and "no proposed sequence" in result.failure


def test_greedy_search_appends_the_best_scored_skill_and_stops_on_any_goal_reaching_candidate() -> None:
    model = RuleModel(
        next_skills=["['pick(blue_box)', 'pick(red_box)']", "['place(red_box, table)', 'place(red_box, rack)']"],
        scores={"pick(red_box)": -1.0, "pick(blue_box)": -2.0, "place(red_box, table)": -0.5, "place(red_box, rack)": -9.0},
    )
    events: list = []
    result = LookaheadPlanner(LookaheadOptions(), "greedy-search").plan(context(model, SymbolicFeasibility(), events))
    # step 1: pick(red_box) scores higher (usefulness from -1 vs -2 nats, equal feasibility); step 2: the
    # goal-reaching place(red_box, rack) wins although the model prefers place(red_box, table)
    assert [str(c) for c in result.skeleton] == ["pick(red_box)", "place(red_box, rack)"]
    assert model.requests == ["next", "score", "next", "score"] and result.llm_calls == 4
    steps = [e for e in events if e["event"] == "greedy_step"]
    assert [c["skill"] for c in steps[0]["candidates"] if c["chosen"]] == ["pick(red_box)"]
    usefulness = [c["usefulness"] for c in steps[0]["candidates"]]
    assert usefulness[1] / usefulness[0] == pytest.approx(np.exp(0.3 * 1.0), rel=1e-3)  # softmax(0.3 ℓ)


def test_hybrid_falls_back_to_a_greedy_step_then_shoots_again_from_the_prefix() -> None:
    model = RuleModel(sequences="[['place(red_box, rack)']]", next_skills=["['pick(red_box)']"], scores={"pick(red_box)": -1.0})
    feasibility = SymbolicFeasibility()
    result = check_task_planner(LookaheadPlanner(LookaheadOptions(), "hybrid"), context(model, feasibility))
    # the first shot places a box that is not held (infeasible), the greedy step picks, the second
    # shot, from the prefix, completes the plan
    assert model.requests[:3] == ["shooting", "next", "score"]
    assert [str(c) for c in result.skeleton] == ["pick(red_box)", "place(red_box, rack)"]
    assert feasibility.calls[-1] == ["pick(red_box)", "place(red_box, rack)"]


def test_a_shots_repeat_of_the_prefix_is_dropped_and_a_partial_one_read_both_ways() -> None:
    pick_red, place_red, pick_hook, pull_blue = (parse_skill_call(t) for t in ("pick(red_box)", "place(red_box, rack)", "pick(hook)", "pull(blue_box, hook)"))
    prefix = [pick_red, place_red, pick_hook]
    assert continuations(prefix, [pick_red, place_red, pick_hook, pull_blue]) == [[pull_blue]]  # the whole prefix again
    assert continuations(prefix, [pick_hook, pull_blue]) == [[pull_blue], [pick_hook, pull_blue]]  # its last skill again
    assert continuations(prefix, [place_red, pick_hook, pull_blue]) == [[pull_blue], [place_red, pick_hook, pull_blue]]
    assert continuations(prefix, [pull_blue]) == [[pull_blue]] and continuations([], [pick_hook]) == [[pick_hook]]


def test_a_shot_that_restarts_at_the_prefixs_last_skill_is_read_as_its_continuation() -> None:
    # the third shot, from [pick(blue_box), place(blue_box, table)], begins with the prefix's last
    # skill: read literally it places a box that is no longer held (0.05, below tau); read with the
    # repeat dropped it reaches the goal
    restart = "[['place(blue_box, table)', 'pick(red_box)', 'place(red_box, rack)']]"
    model = RuleModel(sequences=["[['place(red_box, rack)']]", "[['place(red_box, rack)']]", restart],
                      next_skills=["['pick(blue_box)']", "['place(blue_box, table)']"])
    feasibility = SymbolicFeasibility()
    result = check_task_planner(LookaheadPlanner(LookaheadOptions(), "hybrid"), context(model, feasibility))
    assert model.requests.count("shooting") == 3
    assert [str(c) for c in result.skeleton] == ["pick(blue_box)", "place(blue_box, table)", "pick(red_box)", "place(red_box, rack)"]
    assert result.plan.p_success == pytest.approx(0.9**4)
    literal = ["pick(blue_box)", "place(blue_box, table)", "place(blue_box, table)", "pick(red_box)", "place(red_box, rack)"]
    assert literal in feasibility.calls  # both readings were planned


def test_hybrid_without_reshooting_lets_the_greedy_steps_finish_the_plan() -> None:
    model = RuleModel(sequences="[['place(red_box, rack)']]", next_skills=["['pick(red_box)']", "['place(red_box, rack)']"],
                      scores={"pick(red_box)": -1.0, "place(red_box, rack)": -1.0})
    options = HybridOptions(reshoot="never", proposals="generated")
    result = check_task_planner(LookaheadPlanner(options, "hybrid"), context(model, SymbolicFeasibility()))
    # one shooting query from the empty prefix (infeasible), then greedy steps only: the second step's
    # goal-reaching candidate ends the search without a second shooting query
    assert model.requests == ["shooting", "next", "score", "next", "score"]
    assert [str(c) for c in result.skeleton] == ["pick(red_box)", "place(red_box, rack)"] and result.llm_calls == 5
    assert HybridOptions().reshoot == "never"  # hybrid's default (the published interleaving: paper-search.yaml)


def test_planning_fails_after_the_depth_budget() -> None:
    model = RuleModel(next_skills=["['pick(blue_box)']"], scores={"pick(blue_box)": -1.0})
    result = check_task_planner(LookaheadPlanner(LookaheadOptions(max_depth=3), "greedy-search"), context(model, SymbolicFeasibility()))
    assert not result.found and "within 3 skills" in result.failure and len(result.skeleton) == 3


@pytest.mark.parametrize("drift", [0.0, 0.2])
def test_skipping_revisits_never_returns_to_a_planned_situation(drift: float) -> None:
    def chosen_third(revisits: str) -> str:
        model = RuleModel(next_skills=["['pick(blue_box)']", "['place(blue_box, rack)']", "['pick(blue_box)', 'pick(red_box)']"],
                          scores={"pick(blue_box)": -1.0, "pick(red_box)": -3.0})
        planner = LookaheadPlanner(LookaheadOptions(max_depth=3, revisits=revisits), "greedy-search")
        result = planner.plan(context(model, SymbolicFeasibility(drift=drift)))
        assert not result.found and len(result.skeleton) == 3
        return str(result.skeleton[2])

    # taking the blue box off the rack again repeats the situation after the first step (blue box in
    # hand, the rest as it was), also when the predicted states let the red box drift 0.2 m a step,
    # out of the workspace
    assert chosen_third("allow") == "pick(blue_box)"
    assert chosen_third("skip") == "pick(red_box)"
    assert chosen_third("last") == "pick(red_box)"  # another candidate is left: the revisit waits


def test_a_box_put_back_is_chosen_last_when_no_other_candidate_is_left() -> None:
    # putting the blue box back on the table repeats the start situation: skip ends the search there,
    # last appends it (where a box lands was planned for the prefix alone) and goes on to d_max
    def searched(revisits: str) -> tuple[list[str], str, list]:
        model = RuleModel(next_skills=["['pick(blue_box)']", "['place(blue_box, table)']", "['pick(red_box)']"])
        events: list = []
        result = LookaheadPlanner(LookaheadOptions(max_depth=3, revisits=revisits), "greedy-search").plan(context(model, SymbolicFeasibility(), events))
        steps = [e for e in events if e["event"] == "greedy_step"]
        return [str(c) for c in result.skeleton], result.failure, [(c["skill"], c["revisit"], c["chosen"]) for c in steps[1]["candidates"]]

    skeleton, failure, second = searched("skip")
    assert skeleton == ["pick(blue_box)"] and "already on the plan" in failure
    assert second == [("place(blue_box, table)", True, False)]
    skeleton, failure, second = searched("last")
    assert skeleton == ["pick(blue_box)", "place(blue_box, table)", "pick(red_box)"] and "within 3 skills" in failure
    assert second == [("place(blue_box, table)", True, True)]


@pytest.mark.parametrize("revisits", ["skip", "last"])
def test_skipping_revisits_fails_early_when_every_candidate_revisits(revisits: str) -> None:
    # taking the box off the rack again is a pick: last never appends it either
    model = RuleModel(next_skills=["['pick(blue_box)']", "['place(blue_box, rack)']", "['pick(blue_box)']"])
    events: list = []
    result = LookaheadPlanner(LookaheadOptions(revisits=revisits), "greedy-search").plan(context(model, SymbolicFeasibility(), events))
    assert not result.found and "already on the plan" in result.failure and len(result.skeleton) == 2
    last = [e for e in events if e["event"] == "greedy_step"][-1]
    assert [(c["skill"], c["revisit"], c["chosen"]) for c in last["candidates"]] == [("pick(blue_box)", True, False)]


def test_grounded_proposals_score_every_valid_skill_without_generating() -> None:
    model = RuleModel(scores={"pick(red_box)": -1.0, "pick(blue_box)": -2.0})
    events: list = []
    result = LookaheadPlanner(LookaheadOptions(proposals="grounded"), "greedy-search").plan(context(model, SymbolicFeasibility(), events))
    assert [str(c) for c in result.skeleton] == ["pick(red_box)", "place(red_box, rack)"]
    assert "next" not in model.requests and model.requests == ["score", "score"] and result.llm_calls == 2
    first, second = [{c["skill"] for c in e["candidates"]} for e in events if e["event"] == "greedy_step"]
    assert first == {"pick(red_box)", "pick(blue_box)"}  # nothing in hand: only the two boxes can be picked
    assert {"place(red_box, table)", "place(red_box, rack)"} <= second and not any(s.startswith("pick") for s in second)


def test_a_dead_end_backtracks_to_the_next_best_candidate_of_an_earlier_step() -> None:
    # step 1 prefers the blue box; after it every candidate is below tau, a dead end
    model = RuleModel(next_skills=["['pick(blue_box)', 'pick(red_box)']", "['place(blue_box, rack)']", "['place(red_box, rack)']"],
                      scores={"pick(blue_box)": -1.0, "pick(red_box)": -3.0})
    feasibility = SymbolicFeasibility(values={"place(blue_box, rack)": 0.1})
    options = LookaheadOptions(below_tau="skip", backtracks=1)
    events: list = []
    result = LookaheadPlanner(options, "greedy-search").plan(context(model, feasibility, events))
    assert [str(c) for c in result.skeleton] == ["pick(red_box)", "place(red_box, rack)"]
    assert [e["chosen"] for e in events if e["event"] == "backtrack"] == ["pick(red_box)"]
    model = RuleModel(next_skills=["['pick(blue_box)', 'pick(red_box)']", "['place(blue_box, rack)']"],
                      scores={"pick(blue_box)": -1.0, "pick(red_box)": -3.0})
    without = LookaheadPlanner(LookaheadOptions(below_tau="skip"), "greedy-search").plan(context(model, feasibility))
    assert not without.found and "at or below tau" in without.failure and [str(c) for c in without.skeleton] == ["pick(blue_box)"]


def test_backtracking_never_resumes_the_last_step_where_no_candidate_reached_the_goal() -> None:
    model = RuleModel(scores={"pick(red_box)": -1.0, "pick(blue_box)": -2.0})
    feasibility = SymbolicFeasibility(values={"place(red_box, rack)": 0.1})  # the goal is never reached
    events: list = []
    options = LookaheadOptions(proposals="grounded", max_depth=2, backtracks=5)
    result = LookaheadPlanner(options, "greedy-search").plan(context(model, feasibility, events))
    assert not result.found and "within 2 skills" in result.failure
    # d_max ends the red branch; only the first step's other candidate is worth resuming
    assert [e["chosen"] for e in events if e["event"] == "backtrack"] == ["pick(blue_box)"]
    assert [str(c) for c in result.skeleton][0] == "pick(blue_box)"


@pytest.mark.parametrize("order", ["latest", "most_feasible"])
def test_a_dead_end_resumes_at_the_latest_step_or_at_the_most_feasible_planned_prefix(order: str) -> None:
    # the blue branch needs more than d_max = 3 skills; the root's other candidate, pick(red_box), is
    # planned with p_success 0.9, the second step's other one, place(blue_box, table), with 0.9 · 0.9
    model = RuleModel(scores={"pick(blue_box)": -1.0, "pick(red_box)": -3.0, "place(blue_box, rack)": -1.0})
    feasibility = SymbolicFeasibility(values={"place(blue_box, rack)": 0.5})
    events: list = []
    options = LookaheadOptions(proposals="grounded", max_depth=3, backtracks=1, backtrack_to=order)
    result = LookaheadPlanner(options, "greedy-search").plan(context(model, feasibility, events))
    steps = [e for e in events if e["event"] == "greedy_step"]
    assert [next(c["skill"] for c in s["candidates"] if c["chosen"]) for s in steps[:2]] == ["pick(blue_box)", "place(blue_box, rack)"]
    resumed = [(e["prefix"], e["chosen"]) for e in events if e["event"] == "backtrack"]
    if order == "latest":
        assert resumed[0][0] == ["pick(blue_box)"] and resumed[0][1] != "place(blue_box, rack)"
        assert not result.found  # the one backtrack is spent in the blue branch
    else:
        assert resumed == [([], "pick(red_box)")]
        assert result.found and [str(c) for c in result.skeleton] == ["pick(red_box)", "place(red_box, rack)"]


def test_skipping_regressions_never_takes_a_box_off_the_rack_the_goal_wants_it_on() -> None:
    def search(goal_text: str, regressions: str) -> tuple[list[str], list[dict]]:
        model = RuleModel(next_skills=["['pick(red_box)', 'pick(blue_box)']", "['place(red_box, rack)']", "['pick(red_box)', 'pick(blue_box)']"],
                          scores={"pick(red_box)": -1.0, "pick(blue_box)": -3.0})
        events: list = []
        planning = context(model, SymbolicFeasibility(), events)
        planning = PlanningContext(planning.instruction, parse_goal(goal_text), planning.session, planning.skills, planning.feasibility,
                                   planning.object_names, planning.observation, on_event=planning.on_event)
        result = LookaheadPlanner(LookaheadOptions(max_depth=3, regressions=regressions), "greedy-search").plan(planning)
        steps = [{c["skill"]: c["regression"] for c in e["candidates"]} for e in events if e["event"] == "greedy_step"]
        return [str(c) for c in result.skeleton], steps

    # after red is on the rack, the model prefers picking it up again: a proposition the plan achieved
    both_on_rack = "[['on(red_box, rack)', 'on(blue_box, rack)']]"
    skeleton, steps = search(both_on_rack, "allow")
    assert skeleton[2] == "pick(red_box)" and steps[2] == {"pick(red_box)": True, "pick(blue_box)": False}
    assert search(both_on_rack, "skip")[0][2] == "pick(blue_box)"
    # a goal proposition that held in the start state is not protected: the blue box may be picked
    # up from the table the goal wants it on (task1 moves boxes out of the way "onto the table")
    _, steps = search("[['on(red_box, rack)', 'on(blue_box, table)']]", "skip")
    assert steps[0] == {"pick(red_box)": False, "pick(blue_box)": False}


@pytest.mark.parametrize("prefix_start", ["policy", "planned"])
def test_a_candidate_plan_starts_from_the_planned_prefix_only_when_asked(prefix_start: str) -> None:
    model = RuleModel(next_skills=["['pick(red_box)']", "['place(red_box, rack)']"])
    feasibility = SymbolicFeasibility()
    options = LookaheadOptions(max_depth=3, prefix_start=prefix_start)
    result = LookaheadPlanner(options, "greedy-search").plan(context(model, feasibility))
    assert [str(c) for c in result.skeleton] == ["pick(red_box)", "place(red_box, rack)"]
    assert feasibility.calls == [["pick(red_box)"], ["pick(red_box)", "place(red_box, rack)"]]
    assert feasibility.starts[0] is None  # nothing planned yet
    if prefix_start == "policy":
        assert feasibility.starts[1] is None
    else:  # the one-skill plan's actions: the double's plan of [pick(red_box)] acts -0.5
        np.testing.assert_array_equal(feasibility.starts[1], np.full((1, 4), -0.5, np.float32))
