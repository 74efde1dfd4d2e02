"""The ground-truth scene parser returns the simulator's state in the task's object order."""

from __future__ import annotations

from dataclasses import replace

import pytest
from t2m_scene_truth import hooks
from t2m_scene_truth.parser import GroundTruthSceneParser

from t2m_core.errors import T2MError
from t2m_core.registry import Registry
from t2m_core.testing import check_scene_parser, sample_observation


@pytest.fixture
def parser(t2m_registry: Registry) -> GroundTruthSceneParser:
    t2m_registry.register_plugin(hooks, name="scene_truth")
    return t2m_registry.create("scene_parser", "ground-truth")


def test_returns_the_ground_truth(parser: GroundTruthSceneParser) -> None:
    observation = sample_observation()
    assert check_scene_parser(parser, observation, expected=observation.ground_truth) is observation.ground_truth


def test_orders_and_restricts_to_the_requested_objects(parser: GroundTruthSceneParser) -> None:
    observation = replace(sample_observation(), object_names=("table", "hook", "rack"))
    state = check_scene_parser(parser, observation)
    assert state.object_names == ("table", "hook", "rack")
    assert state.objects["hook"] is observation.ground_truth.objects["hook"]


def test_without_ground_truth_the_error_names_the_fix(parser: GroundTruthSceneParser) -> None:
    with pytest.raises(T2MError, match="needs the simulator's state") as raised:
        parser.parse(sample_observation(with_ground_truth=False))
    assert "scene-file" in (raised.value.hint or "")


def test_missing_object_is_named(parser: GroundTruthSceneParser) -> None:
    observation = replace(sample_observation(), object_names=("table", "rack", "cyan_box"))
    with pytest.raises(T2MError, match="has no object\\(s\\) cyan_box"):
        parser.parse(observation)


def test_alias_truth_resolves(t2m_registry: Registry) -> None:
    t2m_registry.register_plugin(hooks, name="scene_truth")
    assert t2m_registry.get("scene_parser", "truth").name == "ground-truth"
