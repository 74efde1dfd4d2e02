"""``t2m run`` end to end through doubles of the simulator, language model and feasibility planner:
the run directory, the failure types and the exit status (docs/guide/run-records.md)."""

from __future__ import annotations

import json

import pytest
import yaml
from typer.testing import CliRunner

from t2m_core.cli.main import app
from t2m_core.hookspecs import hookimpl
from t2m_core.plugin_specs import FeasibilityPlannerSpec, LanguageModelSpec, SimulatorSpec, SkillLibrarySpec
from tests.core.plugin_doubles import ScriptedSimulator
from tests.plugins.t2m_planners.planner_doubles import RuleModel, SymbolicFeasibility

runner = CliRunner()
SELECTION = ["--sim", "scripted", "--llm", "rule", "--set", "skills.name=none", "--set", "feasibility_planner.name=symbolic",
             "--set", "output.video=false", "--task", "task0", "--seed", "0"]
SOLUTION = "[['pick(yellow_box)', 'place(yellow_box, rack)', 'pick(cyan_box)', 'place(cyan_box, rack)', 'pick(blue_box)', 'place(blue_box, rack)']]"
GOAL = "[['on(yellow_box, rack)', 'on(cyan_box, rack)', 'on(blue_box, rack)']]"


def install(t2m_plugin, model: RuleModel) -> None:
    import t2m_planners.hooks
    import t2m_scene_truth.hooks

    class Doubles:
        @hookimpl
        def t2m_register_simulators(self):
            return [SimulatorSpec(name="scripted", factory=lambda _o: ScriptedSimulator(success=True), summary="double")]

        @hookimpl
        def t2m_register_language_models(self):
            return [LanguageModelSpec(name="rule", factory=lambda _o: model, summary="double")]

        @hookimpl
        def t2m_register_skills(self):
            return [SkillLibrarySpec(name="none", factory=lambda _o: {}, summary="double")]

        @hookimpl
        def t2m_register_feasibility_planners(self):
            return [FeasibilityPlannerSpec(name="symbolic", factory=lambda _o: SymbolicFeasibility(), summary="double")]

    t2m_plugin(Doubles(), name="doubles")
    t2m_plugin(t2m_planners.hooks, name="planners")
    t2m_plugin(t2m_scene_truth.hooks, name="scene-truth")


def test_a_run_records_everything_and_fails_when_the_simulated_goal_does_not_hold(t2m_registry, t2m_plugin, tmp_path) -> None:
    install(t2m_plugin, RuleModel(goal=GOAL, sequences=SOLUTION))
    result = runner.invoke(app, ["run", *SELECTION, "--out", str(tmp_path), "--json"])
    assert result.exit_code == 1, result.output  # the double never moves a box: the goal does not hold
    record = json.loads((tmp_path / "result.json").read_text())
    assert record["format"] == "t2m-run/1" and record["success"] is False
    assert record["failure_type"] == "execution_failure" and "goal does not hold" in record["failure"]
    assert sorted(record["predicted_goal"][0]) == ["on(blue_box, rack)", "on(cyan_box, rack)", "on(yellow_box, rack)"]
    assert len(record["plan"]) == 6 and len(record["executed"]) == 6 and all(step["success"] for step in record["executed"])
    assert record["llm_calls"] == 2 and 0 < record["subgoal_completion"] < 1
    assert yaml.safe_load((tmp_path / "config.yaml").read_text())["task_planner"]["name"] == "hybrid"
    events = [json.loads(line)["event"] for line in (tmp_path / "plan_tree.jsonl").read_text().splitlines()]
    assert events[0] == "goal" and "shooting_candidate" in events and events.count("executed") == 6
    transcript = [json.loads(line) for line in (tmp_path / "transcript.jsonl").read_text().splitlines()]
    assert [r["kind"] for r in transcript] == ["complete", "complete"]
    assert json.loads(result.stdout)["plan"] == record["plan"]


def test_an_instruction_with_no_valid_goal_is_a_planning_failure_with_a_complete_record(t2m_registry, t2m_plugin, tmp_path) -> None:
    install(t2m_plugin, RuleModel(goal="I cannot make a sandwich"))
    result = runner.invoke(app, ["run", *SELECTION, "--instruction", "make me a sandwich", "--out", str(tmp_path)])
    assert result.exit_code == 1
    record = json.loads((tmp_path / "result.json").read_text())
    assert record["failure_type"] == "planning_failure" and record["failure"].startswith("no valid goal")
    assert record["instruction"] == "make me a sandwich" and record["goal_source"] == "predicted"
    assert record["executed"] == [] and record["plan"] == []
    assert (tmp_path / "config.yaml").exists() and (tmp_path / "plan_tree.jsonl").exists()


def test_an_instruction_about_an_absent_object_names_the_objects_there_are(t2m_registry, t2m_plugin, tmp_path) -> None:
    install(t2m_plugin, RuleModel(goal=GOAL))
    result = runner.invoke(app, ["run", *SELECTION, "--instruction", "put the red box on the rack", "--out", str(tmp_path)])
    assert result.exit_code == 1
    record = json.loads((tmp_path / "result.json").read_text())
    assert record["failure_type"] == "planning_failure" and record["failure"].startswith("no valid goal: ")
    assert "red box" in record["failure"] and "blue_box" in record["failure"] and record["llm_calls"] == 0


def test_an_unwritable_run_directory_is_one_line_of_error(t2m_registry, t2m_plugin, tmp_path) -> None:
    install(t2m_plugin, RuleModel(goal=GOAL))
    blocker = tmp_path / "file"
    blocker.write_text("")
    result = runner.invoke(app, ["run", *SELECTION, "--out", str(blocker / "run")])
    assert result.exit_code == 2 and "cannot write to" in result.output
    negative = runner.invoke(app, ["run", *SELECTION[:-2], "--seed", "-1", "--out", str(tmp_path / "x")])
    assert negative.exit_code == 2 and "greater than or equal to 0" in negative.output


class UnresettableSimulator(ScriptedSimulator):
    """A simulator whose every reset fails, as a task's scene sampler does when no candidate is accepted."""

    def reset(self, task, *, seed):
        from t2m_core.errors import T2MError

        raise T2MError(f"no accepted scene for {task.id} from seed {seed}", "try another seed")


def test_an_episode_stopped_by_an_error_says_so_and_is_run_again_by_a_resumed_evaluation(t2m_registry, t2m_plugin, tmp_path) -> None:
    from t2m_core.evaluation import Episode, finished

    install(t2m_plugin, RuleModel(goal=GOAL, sequences=SOLUTION))

    class Broken:
        @hookimpl
        def t2m_register_simulators(self):
            return [SimulatorSpec(name="unresettable", factory=lambda _o: UnresettableSimulator(success=True), summary="double")]

    t2m_plugin(Broken(), name="broken")
    episode = Episode("hybrid", "task0", 0)
    directory = episode.directory(tmp_path)
    result = runner.invoke(app, ["run", *SELECTION, "--sim", "unresettable", "--out", str(directory)])
    assert result.exit_code != 0 and "no accepted scene for task0 from seed 0" in result.output
    record = json.loads((directory / "result.json").read_text())
    assert record["error"].startswith("T2MError: no accepted scene for task0 from seed 0")
    assert record["success"] is False and record["failure_type"] is None and record["interrupted"] is False
    assert finished(episode, tmp_path) is None  # resuming reruns it
    del record["error"]  # the same record as written before the field existed
    (directory / "result.json").write_text(json.dumps(record))
    assert finished(episode, tmp_path) is None
    (directory / "result.json").write_text(json.dumps({**record, "error": "T2MError: no accepted scene"}))
    shown = runner.invoke(app, ["show", str(directory)])
    assert shown.exit_code == 0 and "stopped by an error: T2MError: no accepted scene" in shown.output


def test_a_run_replayed_from_its_transcript_takes_the_same_decisions(t2m_registry, t2m_plugin, tmp_path) -> None:
    import t2m_llm_replay.hooks

    model = RuleModel(goal=GOAL, sequences="[['pick(yellow_box)']]", next_skills=["['pick(yellow_box)', 'pick(cyan_box)']"],
                      scores={"pick(cyan_box)": -1.0, "pick(yellow_box)": -2.0})
    install(t2m_plugin, model)
    t2m_plugin(t2m_llm_replay.hooks, name="replay")
    first = runner.invoke(app, ["run", *SELECTION, "--set", "task_planner.options.max_depth=3", "--out", str(tmp_path / "first")])
    asked = list(model.requests)
    replay = [*SELECTION, "--llm", "replay", "--set", f"language_model.options.transcript={tmp_path / 'first' / 'transcript.jsonl'}"]
    second = runner.invoke(app, ["run", *replay, "--set", "task_planner.options.max_depth=3", "--out", str(tmp_path / "second")])
    assert first.exit_code == second.exit_code and first.exit_code in (0, 1)

    def decisions(run: str) -> list[dict]:
        lines = (tmp_path / run / "plan_tree.jsonl").read_text().splitlines()
        return [json.loads(line) for line in lines]

    assert decisions("first") == decisions("second") and len(decisions("first")) > 3
    assert asked.count("score") >= 2 and model.requests == asked  # the replayed run asked the recorded answers, not the model


@pytest.mark.parametrize(("example_plans", "marker"), [("steps", "\nExecuted action: "), ("sequence", "\nTop robot action sequence: ['")])
def test_the_prompts_setting_reaches_the_step_wise_prompts(t2m_registry, t2m_plugin, tmp_path, example_plans, marker) -> None:
    install(t2m_plugin, RuleModel(goal="[['on(yellow_box, rack)']]", next_skills=["['pick(yellow_box)']", "['place(yellow_box, rack)']"]))
    result = runner.invoke(app, ["run", *SELECTION, "--planner", "greedy-search", "--set", f"prompts.example_plans={example_plans}",
                                 "--out", str(tmp_path)])
    assert result.exit_code in (0, 1), result.output
    transcript = [json.loads(line) for line in (tmp_path / "transcript.jsonl").read_text().splitlines()]
    scoring = [r["request"]["prompt"] for r in transcript if r["kind"] == "score"]
    assert scoring, [r["kind"] for r in transcript]
    examples = scoring[0].split("\n\n")[1:-1]
    assert len(examples) == 10 and all(marker in block for block in examples)
    assert yaml.safe_load((tmp_path / "config.yaml").read_text())["prompts"]["example_plans"] == example_plans
