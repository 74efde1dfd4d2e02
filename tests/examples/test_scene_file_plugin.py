"""The example third-party plugin is discovered through its entry point, with no change to t2m."""

from __future__ import annotations

import json

import numpy as np
from typer.testing import CliRunner

from t2m_core.cli.main import app
from t2m_core.protocols import SceneObservation
from t2m_core.registry import get_registry
from t2m_core.testing import check_import_light, check_scene_parser
from tests.examples.scene_file_install import EXAMPLE, install_example


def test_scene_file_plugin_is_discovered_and_listed(t2m_fake_distribution, monkeypatch) -> None:
    install_example(t2m_fake_distribution, monkeypatch)
    result = CliRunner().invoke(app, ["list-plugins", "--json"])
    assert result.exit_code == 0, result.output
    row = next(row for row in json.loads(result.stdout) if row["name"] == "scene-file")
    assert row["kind"] == "scene_parser"
    assert (row["provider"], row["version"], row["status"], row["aliases"]) == (
        "t2m-scene-file",
        "0.1.0",
        "ok",
        ["measured"],
    )


def test_scene_file_parser_is_built_by_the_registry(t2m_fake_distribution, monkeypatch) -> None:
    install_example(t2m_fake_distribution, monkeypatch)
    parser = get_registry().create("scene_parser", "measured", {"path": str(EXAMPLE / "scenes" / "example.yaml")})
    state = check_scene_parser(
        parser, SceneObservation(object_names=("table", "rack", "blue_box", "yellow_box", "cyan_box"))
    )
    np.testing.assert_allclose(state.objects["rack"].position, [0.44, -0.33, 0.16])


def test_scene_file_options_are_checked_by_config_validate(t2m_fake_distribution, monkeypatch) -> None:
    install_example(t2m_fake_distribution, monkeypatch)
    result = CliRunner().invoke(
        app,
        [
            "config",
            "validate",
            "--set",
            "scene_parser.name=scene-file",
            "--set",
            "scene_parser.options.size_tolerance=-1",
            "--json",
        ],
    )
    errors = {error["path"]: error["message"] for error in json.loads(result.stdout)["errors"]}
    assert errors["scene_parser.options.path"] == "required key is missing"
    assert errors["scene_parser.options.size_tolerance"] == "Input should be greater than 0"


def test_scene_file_hooks_are_import_light(monkeypatch) -> None:
    monkeypatch.syspath_prepend(str(EXAMPLE))
    check_import_light("t2m_scene_file.hooks")
