"""Every shipped example config is a valid run configuration for the components it names."""

from __future__ import annotations

from pathlib import Path

import pytest

from t2m_core.config import RunConfig, resolve_config
from t2m_core.errors import ConfigError
from t2m_core.registry import Registry, get_registry
from tests.examples.scene_file_install import install_example

CONFIGS = Path(__file__).parents[2] / "examples" / "configs"


def test_there_are_example_configs() -> None:
    assert {path.name for path in CONFIGS.glob("*.yaml")} >= {"default.yaml", "hosted-llm.yaml", "measured-scene.yaml", "paper-search.yaml"}


def test_default_yaml_is_exactly_the_defaults() -> None:
    assert resolve_config([CONFIGS / "default.yaml"]) == RunConfig()
    assert resolve_config([CONFIGS / "default.yaml"], registry=get_registry()) == resolve_config(
        registry=get_registry()
    )


def test_hosted_llm_selects_litellm_with_the_alias_model() -> None:
    config = resolve_config([CONFIGS / "hosted-llm.yaml"], registry=get_registry())
    assert config.language_model.name == "gpt-4o"
    assert (config.language_model.options["model"], config.language_model.options["timeout_s"]) == ("gpt-4o", 60.0)


def test_measured_scene_validates_once_the_example_plugin_is_installed(t2m_fake_distribution, monkeypatch) -> None:
    builtins_only = Registry.from_entry_points(autoload=False)
    with pytest.raises(ConfigError, match="unknown scene parser 'scene-file'"):
        resolve_config([CONFIGS / "measured-scene.yaml"], registry=builtins_only)
    install_example(t2m_fake_distribution, monkeypatch)
    config = resolve_config([CONFIGS / "measured-scene.yaml"], registry=get_registry())
    assert config.scene_parser.options == {
        "path": "examples/t2m-scene-file/scenes/example.yaml",
        "size_tolerance": 0.01,
    }


def test_paper_search_restores_the_published_greedy_step_in_hybrid() -> None:
    from t2m_planners.options import HybridOptions, LookaheadOptions

    config = resolve_config([CONFIGS / "paper-search.yaml"], registry=get_registry())
    assert config.task_planner.name == "hybrid"
    published = HybridOptions(**config.task_planner.options)
    assert (published.proposals, published.revisits, published.below_tau, published.backtracks) == ("generated", "allow", "allow", 0)
    assert published.reshoot == "every_step"  # the published interleaving: shooting again after every greedy step
    # greedy-search's defaults are the published ones
    assert published.model_dump(exclude={"reshoot"}) == LookaheadOptions().model_dump()
    assert HybridOptions().model_dump() != LookaheadOptions().model_dump()
    assert (published.tau, published.regressions, published.backtrack_to) == (0.2, "allow", "latest")
    defaults = HybridOptions()  # docs/guide/deviations.md#tau-01-for-pessimistic-values
    assert (defaults.tau, defaults.regressions, defaults.backtrack_to) == (0.1, "skip", "most_feasible")
