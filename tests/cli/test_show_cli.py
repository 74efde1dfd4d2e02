"""``t2m show``: a run or evaluation directory in words."""

from __future__ import annotations

import json
from pathlib import Path

from typer.testing import CliRunner

from t2m_core.cli.main import USER_ERROR_EXIT_CODE, app

runner = CliRunner()

TREE = [
    {"event": "goal", "goal": [["on(red_box, rack)"]], "attempts": []},
    {"event": "greedy_step", "prefix": [], "candidates": [
        {"skill": "pick(red_box)", "usefulness": 0.7, "feasibility": 0.9, "score": 0.63, "p_success": 0.9, "chosen": True},
        {"skill": "pick(hook)", "usefulness": 0.3, "feasibility": 0.5, "score": 0.15, "p_success": 0.5, "chosen": False, "revisit": True}]},
    {"event": "backtrack", "prefix": [], "chosen": "pick(hook)", "reason": "no candidate next skill can be chosen"},
    {"event": "plan", "skeleton": ["pick(red_box)", "place(red_box, rack)"], "found": True, "failure": None, "p_success": 0.8},
    {"event": "executed", "skill": "pick(red_box)", "value": 0.9, "success": True, "failure": None},
    {"event": "executed", "skill": "place(red_box, rack)", "value": 0.8, "success": False, "failure": "collision"},
]


def write_run(directory: Path, success: bool, tree: list | None = TREE) -> None:
    directory.mkdir(parents=True)
    if tree is not None:
        (directory / "plan_tree.jsonl").write_text("".join(json.dumps(r) + "\n" for r in tree))
    (directory / "result.json").write_text(json.dumps({
        "task": "task0", "seed": 0, "planner": "hybrid", "instruction": "put the red box on the rack", "success": success,
        "failure_type": None if success else "execution_failure", "failure": None if success else "place(red_box, rack) failed: collision",
        "plan": ["pick(red_box)", "place(red_box, rack)"], "executed": [{}, {}], "subgoal_completion": 1.0 if success else 0.5,
        "llm_calls": 3, "stap_calls": 4, "timings": {"total": 12.0}}))


def test_a_run_directory_replays_its_plan_tree_and_outcome(tmp_path: Path) -> None:
    write_run(tmp_path / "run", success=False)
    result = runner.invoke(app, ["show", str(tmp_path / "run")])
    assert result.exit_code == 0, result.output
    lines = result.stdout.splitlines()
    assert "put the red box on the rack" in lines[0]
    assert any("pick(red_box): usefulness 0.70 x feasibility 0.90 = 0.630" in line and "<-" in line for line in lines)
    assert any("pick(hook)" in line and "revisit" in line for line in lines)
    assert any(line.strip().startswith("backtrack") for line in lines)
    assert "executed place(red_box, rack) (value 0.80): collision" in result.stdout
    assert lines[-1].startswith("execution_failure: place(red_box, rack) failed: collision; subgoal completion 0.50")


def test_an_evaluation_directory_lists_why_each_episode_failed(tmp_path: Path) -> None:
    write_run(tmp_path / "hybrid" / "task0" / "seed0", success=True)
    write_run(tmp_path / "hybrid" / "task0" / "seed1", success=False)
    result = runner.invoke(app, ["show", str(tmp_path), "--failures"])
    assert result.exit_code == 0, result.output
    assert result.stdout.splitlines() == ["hybrid/task0/seed1: execution_failure: place(red_box, rack) failed: collision (plan of 2, 2 executed)"]


def test_a_damaged_record_or_a_foreign_directory_is_a_clear_error(tmp_path: Path) -> None:
    write_run(tmp_path / "run", success=True, tree=None)
    (tmp_path / "run" / "plan_tree.jsonl").write_text('{"event": "goal", "goal": null}\nnot json\n')
    result = runner.invoke(app, ["show", str(tmp_path / "run")])
    assert result.exit_code == USER_ERROR_EXIT_CODE and "plan_tree.jsonl, line 2, is not a plan-tree record" in result.output
    result = runner.invoke(app, ["show", str(tmp_path / "run" / "nothing")])
    assert result.exit_code == USER_ERROR_EXIT_CODE and "neither a run record nor finished evaluation episodes" in result.output
