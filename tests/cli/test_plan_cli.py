"""``t2m plan``: a skeleton planned from a task's scene, with the shipped skills and the real simulator."""

from __future__ import annotations

import json

from typer.testing import CliRunner

from t2m_core.cli.main import app

runner = CliRunner()


def test_plan_prints_one_row_per_skill_of_the_skeleton() -> None:
    result = runner.invoke(app, ["plan", "--task", "task4", "--seed", "0", "--skeleton", "pick(hook), pull(blue_box, hook)",
                                 "--set", "feasibility_planner.options.population=50", "--json"])
    assert result.exit_code == 0, result.output
    report = json.loads(result.stdout[result.stdout.index("{"):])
    assert [row["skill"] for row in report["plan"]] == ["pick(hook)", "pull(blue_box, hook)"]
    assert all(len(row["action"]) == 4 and all(-1 <= a <= 1 for a in row["action"]) for row in report["plan"])
    assert 0.0 <= report["p_success"] <= 1.0


def test_a_bad_skeleton_is_one_line_of_error() -> None:
    for skeleton, problem in ((" , ", "empty skeleton"), ("pick(hook), pull(green_box, hook)", "green_box")):
        result = runner.invoke(app, ["plan", "--task", "task4", "--seed", "0", "--skeleton", skeleton])
        assert result.exit_code == 2, result.output
        assert problem in result.output and "Traceback" not in result.output
