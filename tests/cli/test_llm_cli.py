"""``t2m llm goal`` and ``t2m llm next`` with a scripted language model (test double) and replay."""

from __future__ import annotations

import json
from types import SimpleNamespace

import pytest
from t2m_llm_replay import hooks as replay_hooks
from typer.testing import CliRunner

from t2m_core.cli.main import app
from t2m_core.hookspecs import hookimpl
from t2m_core.language.transcript import read_transcript
from t2m_core.plugin_specs import LanguageModelSpec
from t2m_core.protocols import LanguageModelCapabilities

runner = CliRunner()


class ScriptedModel:
    """Answers goal prompts with task3's goal (first answer invalid), next-skill prompts with a list."""

    capabilities = LanguageModelCapabilities(exact_scoring=True, grammar=False)

    def __init__(self, _options=None):
        self.goal_answers = ["[['on(green_box, rack)']]", " [['on(red_box, rack)', 'on(blue_box, rack)'], "
                             "['on(red_box, rack)', 'on(yellow_box, rack)'], ['on(yellow_box, rack)', 'on(blue_box, rack)']]"]

    def complete(self, prompt, *, max_tokens=256, stop=(), temperature=0.0, n=1, grammar=None):
        if prompt.endswith("(python list of lists):"):
            return [self.goal_answers.pop(0) if len(self.goal_answers) > 1 else self.goal_answers[0]] * n
        return [" ['pick(hook)', 'pick(red_box)', 'fly(hook)', 'pick(red_box)']"] * n

    def score(self, prompt, candidates):
        return [-float(len(candidate)) for candidate in candidates]


@pytest.fixture
def scripted(t2m_registry, t2m_plugin):
    def register():
        return [LanguageModelSpec(name="scripted", factory=ScriptedModel, summary="test double")]

    t2m_plugin(SimpleNamespace(t2m_register_language_models=hookimpl(register)), name="scripted")
    t2m_plugin(replay_hooks, name="replay")
    return t2m_registry


def test_goal_reports_attempts_validity_and_the_match(scripted, tmp_path):
    transcript = tmp_path / "t.jsonl"
    result = runner.invoke(app, ["llm", "goal", "--task", "task3", "--seed", "0", "--llm", "scripted", "--json",
                                 "--transcript", str(transcript)])
    assert result.exit_code == 0, result.output
    report = json.loads(result.stdout)
    assert report["valid"] and report["matches_task_goal"]
    assert [attempt["problem"] is None for attempt in report["attempts"]] == [False, True]
    assert "green_box" in report["attempts"][0]["problem"]
    assert len(read_transcript(transcript)) == 2

    # the transcript replays the same command offline
    replayed = runner.invoke(app, ["llm", "goal", "--task", "task3", "--seed", "0", "--llm", "replay", "--json",
                                   "--set", f"transcript={transcript}"])
    assert replayed.exit_code == 0, replayed.output
    assert json.loads(replayed.stdout)["goal"] == report["goal"]


def test_next_ranks_the_valid_distinct_candidates(scripted):
    result = runner.invoke(app, ["llm", "next", "--task", "task3", "--seed", "0", "--llm", "scripted", "--goal", "task",
                                 "--executed", "pick(red_box),place(red_box, rack)", "--json"])
    assert result.exit_code == 0, result.output
    report = json.loads(result.stdout)
    assert report["executed"] == ["pick(red_box)", "place(red_box, rack)"]
    assert "on(red_box, rack)" in report["relationships"]
    assert [row["skill"] for row in report["candidates"]] == ["pick(hook)", "pick(red_box)"]
    assert report["candidates"][0]["usefulness"] > report["candidates"][1]["usefulness"]
    assert sum(row["usefulness"] for row in report["candidates"]) == pytest.approx(1.0)


def test_bad_executed_skill_and_unknown_model_are_clear_errors(scripted):
    result = runner.invoke(app, ["llm", "next", "--task", "task3", "--llm", "scripted", "--goal", "task",
                                 "--executed", "pick(green_box)"])
    assert result.exit_code != 0 and "green_box" in result.output
    result = runner.invoke(app, ["llm", "goal", "--task", "task3", "--llm", "scriptd"])
    assert result.exit_code != 0 and "did you mean 'scripted'" in result.output


def test_table_output(scripted):
    result = runner.invoke(app, ["llm", "goal", "--task", "task3", "--llm", "scripted"])
    assert result.exit_code == 0, result.output
    assert "alternative 3" in result.output and "matches the task's goal alternatives: True" in result.output


class WrongGoalModel(ScriptedModel):
    """Answers every goal prompt with a valid goal that is not task3's."""

    def __init__(self, _options=None):
        self.goal_answers = ["[['on(red_box, rack)']]"]


@pytest.mark.parametrize("as_json", [True, False])
def test_goal_exits_nonzero_on_a_valid_but_wrong_goal(t2m_registry, t2m_plugin, as_json):
    def register():
        return [LanguageModelSpec(name="wrong-goal", factory=WrongGoalModel, summary="test double")]

    t2m_plugin(SimpleNamespace(t2m_register_language_models=hookimpl(register)), name="wrong-goal")
    result = runner.invoke(app, ["llm", "goal", "--task", "task3", "--llm", "wrong-goal", *(["--json"] if as_json else [])])
    assert result.exit_code == 1, result.output
    if as_json:
        report = json.loads(result.stdout)
        assert report["valid"] and not report["matches_task_goal"]
    else:
        assert "matches the task's goal alternatives: False" in result.output


def test_goal_of_another_instruction_and_a_clear_no_valid_goal(scripted):
    result = runner.invoke(app, ["llm", "goal", "--task", "task3", "--llm", "scripted", "--json",
                                 "--instruction", "Put the red box and the blue box on the rack."])
    report = json.loads(result.stdout)
    assert result.exit_code == 0 and report["matches_task_goal"] is None  # not the task's own instruction
    assert report["instruction"] == "Put the red box and the blue box on the rack."
    refused = runner.invoke(app, ["llm", "goal", "--task", "task3", "--llm", "scripted", "--instruction", "Sing me a song."])
    assert refused.exit_code == 1 and "no valid goal" in refused.output and "none of the world's objects" in refused.output
