"""The evaluation grid: spaced seeds, resuming, the results table."""

from __future__ import annotations

import json

import pytest

from t2m_core.errors import T2MError
from t2m_core.evaluation import SEED_SPACING, Episode, episode_rows, finished, grid, parse_seed_indices, summarise, write_tables


def result(success: bool, failure_type: str | None, seconds: float, interrupted: bool = False) -> dict:
    return {"success": success, "failure_type": failure_type, "subgoal_completion": 1.0 if success else 0.5, "llm_calls": 4,
            "interrupted": interrupted, "timings": {"total": seconds, "language_model": seconds / 2, "feasibility": 1.0, "simulation": 2.0}}


def test_the_grid_spaces_base_seeds_and_names_a_directory_per_episode(tmp_path) -> None:
    episodes = grid(["hybrid", "shooting"], ["task0", "task1"], [0, 1, 2])
    assert len(episodes) == 12 and len({e.directory(tmp_path) for e in episodes}) == 12
    assert [e.seed for e in episodes[:3]] == [0, SEED_SPACING, 2 * SEED_SPACING]


def test_only_episodes_that_ran_to_their_end_count_as_finished(tmp_path) -> None:
    done, failed, killed, torn, broken, unended = (Episode("hybrid", "task0", s) for s in range(6))
    contents = ((done, result(True, None, 3.0)), (failed, result(False, "execution_failure", 3.0)), (killed, result(False, None, 1.0, True)),
                (torn, "{"), (broken, {**result(False, None, 1.0), "error": "RuntimeError: boom"}), (unended, result(False, None, 1.0)))
    for episode, content in contents:
        episode.directory(tmp_path).mkdir(parents=True)
        (episode.directory(tmp_path) / "result.json").write_text(content if isinstance(content, str) else json.dumps(content))
    assert finished(done, tmp_path)["success"] is True and finished(failed, tmp_path)["failure_type"] == "execution_failure"
    assert [finished(e, tmp_path) for e in (killed, torn, broken, unended)] == [None] * 4
    assert finished(Episode("hybrid", "task0", 6), tmp_path) is None


def test_the_table_counts_success_and_failure_types_per_task_and_overall(tmp_path) -> None:
    results = {
        Episode("hybrid", "task0", 0): result(True, None, 10.0),
        Episode("hybrid", "task0", 1): result(False, "planning_failure", 20.0),
        Episode("hybrid", "task1", 0): result(False, "execution_failure", 30.0),
        Episode("hybrid", "task1", 1): result(True, None, 40.0),
    }
    rows = {(r["planner"], r["task"]): r for r in summarise(results)}
    assert rows[("hybrid", "task0")]["success"] == 0.5 and rows[("hybrid", "task0")]["planning_failures"] == 1
    overall = rows[("hybrid", "all")]
    assert (overall["episodes"], overall["success"], overall["execution_failures"]) == (4, 0.5, 1)
    assert overall["seconds_median"] == 25.0 and overall["subgoal_completion"] == 0.75
    write_tables(list(rows.values()), tmp_path, episodes=episode_rows(results))
    assert "| hybrid | all | 4 | 0.5 |" in (tmp_path / "results.md").read_text()
    episodes = (tmp_path / "episodes.csv").read_text().splitlines()
    assert episodes[0].startswith("planner,task,seed_index,success,failure_type") and len(episodes) == 5
    assert episodes[2].startswith("hybrid,task0,1,False,planning_failure") and episodes[3].startswith("hybrid,task1,0,False,execution_failure")
    assert (tmp_path / "success.png").read_bytes()[:4] == b"\x89PNG"
    assert (tmp_path / "results.csv").read_text().splitlines()[0].startswith("planner,task,episodes,success")


def test_resuming_refuses_finished_episodes_run_with_another_configuration(tmp_path) -> None:
    import yaml

    from t2m_core.config.resolve import resolve_config
    from t2m_core.errors import ConfigError
    from t2m_core.evaluation import check_finished_configs, config_conflicts, run_grid
    from t2m_core.registry import get_registry

    episode = Episode("hybrid", "task0", 0)
    directory = episode.directory(tmp_path)
    directory.mkdir(parents=True)
    (directory / "result.json").write_text(json.dumps(result(True, None, 3.0)))
    config = resolve_config(flags={"planner": "hybrid", "task": "task0", "seed": 0}, registry=get_registry()).model_dump(mode="json")
    del config["task_planner"]["options"]["backtracks"]  # a record from before an option existed
    default_tau = config["task_planner"]["options"]["tau"]
    config["task_planner"]["options"]["tau"] = 0.3
    (directory / "config.yaml").write_text(yaml.safe_dump(config))
    assert config_conflicts({"a": {"b": 1, "c": 2}}, {"a": {"b": 1, "c": 3, "d": 4}}) == ["a.c: 2 -> 3"]
    check_finished_configs([episode], tmp_path, ["task_planner.options.tau=0.3"])  # the same values: resumable
    with pytest.raises(ConfigError) as error:
        run_grid([episode], tmp_path, [], executor=object())  # refused before any episode would run
    assert f"task_planner.options.tau: 0.3 -> {default_tau}" in str(error.value) and str(directory) in str(error.value)
    assert "another --out" in error.value.hint


def test_seed_indices_are_a_range_or_a_list_and_never_negative() -> None:
    assert parse_seed_indices("0-3") == [0, 1, 2, 3] and parse_seed_indices("5") == [5] and parse_seed_indices("2,7") == [2, 7]
    for text in ("a-b", "3-1", "-2", ""):
        with pytest.raises(T2MError):
            parse_seed_indices(text)
