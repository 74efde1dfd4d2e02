"""``t2m tasks`` and ``t2m tasks show``."""

from __future__ import annotations

import json

import numpy as np
from typer.testing import CliRunner

from t2m_core.cli.main import app
from t2m_core.domain.sampling import sample_task
from t2m_core.tasks import load_task

runner = CliRunner()


def test_tasks_json_lists_the_suite() -> None:
    result = runner.invoke(app, ["tasks", "--json"])
    assert result.exit_code == 0, result.output
    rows = json.loads(result.stdout)
    assert [row["id"] for row in rows] == [f"task{i}" for i in range(7)]
    assert rows[0]["instruction"] == "How would you pick and place all of the boxes onto the rack?"
    assert rows[3]["properties"] == ["LH", "LG", "PAP"]
    assert rows[1]["objects"] == ["table", "rack", "hook", "cyan_box", "yellow_box", "blue_box"]


def test_tasks_table_for_humans() -> None:
    result = runner.invoke(app, ["tasks"])
    assert result.exit_code == 0, result.output
    assert "lh_lg_po_2" in result.stdout and "LH, LG, PAP" in result.stdout
    assert "How would you get two boxes onto the" in result.stdout


def test_show_json_matches_the_sampler() -> None:
    result = runner.invoke(app, ["tasks", "show", "task1", "--seed", "3", "--json"])
    assert result.exit_code == 0, result.output
    report = json.loads(result.stdout)
    expected = sample_task(load_task("task1"), 3)
    assert report["task"] == "task1" and report["seed"] == 3
    assert (report["accepted_seed"], report["rejections"]) == (expected.accepted_seed, expected.rejections)
    assert report["accepted_seed"] == 3 + report["rejections"]
    assert [o["name"] for o in report["objects"]] == ["table", "rack", "hook", "cyan_box", "yellow_box", "blue_box"]
    hook = next(o for o in report["objects"] if o["name"] == "hook")
    np.testing.assert_allclose(hook["position"], expected.state.objects["hook"].position, atol=1e-6)
    assert hook["size"] == [0.4, 0.22, 0.04]
    assert "on(cyan_box, table)" in report["symbolic_state"]
    assert "on(rack, table)" in report["symbolic_state"]
    assert report["robot_pose"]["position"][2] == 0.4


def test_show_accepts_numbers_and_prints_a_table() -> None:
    result = runner.invoke(app, ["tasks", "show", "0", "--seed", "2"])
    assert result.exit_code == 0, result.output
    assert "task0 seed 2: accepted seed" in result.stdout
    assert "yellow_box" in result.stdout and "symbolic state: on(rack, table)" in result.stdout


def test_unknown_task_names_the_choices() -> None:
    result = runner.invoke(app, ["tasks", "show", "task9"])
    assert result.exit_code == 2
    assert "unknown task 'task9'" in result.stderr
    assert "task0, task1, task2, task3, task4, task5, task6" in result.stderr
