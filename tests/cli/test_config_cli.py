"""``t2m config show|validate|schema`` against an isolated registry of toy components."""

from __future__ import annotations

import json
from pathlib import Path

import jsonschema
import pytest
import yaml
from typer.testing import CliRunner

from t2m_core.cli.main import app
from tests.core.plugin_doubles import EveryKind

runner = CliRunner()

TOY_SELECTION = [
    "--sim", "toysim", "--llm", "toy-llm", "--set", "scene_parser.name=toy-parser",
    "--set", "skills.name=toy-skills", "--set", "feasibility_planner.name=toy-cem", "--planner", "toy-hybrid",
]


@pytest.fixture(autouse=True)
def toy_components(t2m_registry, t2m_plugin) -> None:
    t2m_plugin(EveryKind(), name="every-kind", provider="acme-t2m")


def test_show_resolves_files_flags_and_overrides(tmp_path: Path) -> None:
    config = tmp_path / "run.yaml"
    config.write_text("seed: 3\ntask: task2\nsimulator: {name: toysim, options: {substeps: 2}}\n", encoding="utf-8")
    result = runner.invoke(
        app, ["config", "show", "--config", str(config), *TOY_SELECTION, "--seed", "4", "--set", "seed=5"]
    )
    assert result.exit_code == 0, result.output
    shown = yaml.safe_load(result.stdout)
    assert (shown["task"], shown["seed"]) == ("task2", 5)
    assert shown["simulator"] == {"name": "toysim", "options": {"timestep": 0.002, "substeps": 2}}
    assert shown["skills"] == {"name": "toy-skills", "options": {}}
    as_json = runner.invoke(
        app, ["config", "show", "--config", str(config), *TOY_SELECTION, "--seed", "4", "--set", "seed=5", "--json"]
    )
    assert json.loads(as_json.stdout) == shown


def test_show_rejects_an_unknown_name_with_a_suggestion() -> None:
    result = runner.invoke(app, ["config", "show", *TOY_SELECTION, "--planner", "toy-hybird"])
    assert result.exit_code == 2
    assert "task_planner.name: unknown task planner 'toy-hybird'; did you mean 'toy-hybrid'?" in result.stderr
    assert result.stdout == ""


def test_validate_reports_every_problem_with_its_path(tmp_path: Path) -> None:
    config = tmp_path / "bad.yaml"
    config.write_text("simulator: {name: toysim, options: {timestep: 0}}\noutput: {vidoe: true}\n", encoding="utf-8")
    result = runner.invoke(app, ["config", "validate", "-c", str(config), *TOY_SELECTION[2:], "--json"])
    assert result.exit_code == 1
    report = json.loads(result.stdout)
    assert report["valid"] is False
    # structural problems and the plugin's own option problems, in one pass
    assert [(error["path"], error["source"]) for error in report["errors"]] == [
        ("output.vidoe", str(config)),
        ("simulator.options.timestep", str(config)),
    ]
    result = runner.invoke(app, ["config", "validate", "-c", str(config), *TOY_SELECTION[2:]])
    assert result.exit_code == 1
    assert "✗ output.vidoe: unknown key; did you mean 'video'?" in result.stderr
    assert "✗ simulator.options.timestep: Input should be greater than 0" in result.stderr


def test_validate_accepts_a_good_config() -> None:
    result = runner.invoke(app, ["config", "validate", *TOY_SELECTION])
    assert result.exit_code == 0
    assert "configuration is valid" in result.stderr


def test_schema_is_json_schema_including_plugin_options() -> None:
    result = runner.invoke(app, ["config", "schema"])
    assert result.exit_code == 0
    schema = json.loads(result.stdout)
    jsonschema.Draft202012Validator.check_schema(schema)
    assert "toysim" in result.stdout and "substeps" in result.stdout


def test_bad_override_is_a_clean_error() -> None:
    result = runner.invoke(app, ["config", "show", "--set", "seed"])
    assert result.exit_code == 2
    assert result.stderr.startswith("Error: invalid --set 'seed'")
    assert "Hint: write it as --set dotted.key=value" in result.stderr
