"""The scene-file parser: units, resting heights, orientation, size checks and clear errors."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from t2m_scene_file import hooks
from t2m_scene_file.hooks import SceneFileOptions
from t2m_scene_file.parser import SceneFileError, SceneFileParser

from t2m_core.domain.geometry import quat_yaw
from t2m_core.protocols import SceneObservation
from t2m_core.testing import check_plugin_module, check_scene_parser

EXAMPLE = Path(__file__).parents[1] / "scenes" / "example.yaml"
TASK0_OBJECTS = ("table", "rack", "blue_box", "yellow_box", "cyan_box")


def parser_for(tmp_path: Path, scene: dict, **options: float) -> SceneFileParser:
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(scene), encoding="utf-8")
    return SceneFileParser(SceneFileOptions(path=path, **options))


def test_hooks_module_registers_a_conforming_spec() -> None:
    (spec,) = check_plugin_module(hooks)
    assert (spec.name, spec.aliases) == ("scene-file", ("measured",))


def test_example_scene_parses_in_centimetres_and_degrees() -> None:
    parser = SceneFileParser(SceneFileOptions(path=EXAMPLE))
    state = check_scene_parser(parser, SceneObservation(object_names=TASK0_OBJECTS))
    np.testing.assert_allclose(state.objects["rack"].position, [0.44, -0.33, 0.16])  # top plate 16 cm up
    np.testing.assert_allclose(state.objects["blue_box"].position, [0.50, 0.12, 0.053])  # half of 0.106 m
    np.testing.assert_allclose(state.objects["cyan_box"].position, [0.47, 0.25, 0.035])
    assert quat_yaw(state.objects["yellow_box"].quaternion) == pytest.approx(np.radians(-20))
    np.testing.assert_array_equal(state.objects["table"].position, np.zeros(3))
    assert state.held is None


def test_metres_radians_quaternion_and_end_effector(tmp_path: Path) -> None:
    parser = parser_for(
        tmp_path,
        {
            "objects": [
                {"name": "hook", "position": [0.35, 0.2, 0.03], "quaternion": [0, 0, 0.7071068, 0.7071068]},
                {"name": "red_box", "position": [0.5, 0.0], "yaw": 0.5},
            ],
            "end_effector": {"position": [0.3, 0.0, 0.25]},
            "held": "hook",
        },
    )
    state = parser.parse(SceneObservation(object_names=()))  # no task order: table, then file order
    assert state.object_names == ("table", "hook", "red_box")
    assert quat_yaw(state.objects["hook"].quaternion) == pytest.approx(np.pi / 2)
    assert quat_yaw(state.objects["red_box"].quaternion) == pytest.approx(0.5)
    np.testing.assert_allclose(state.objects["red_box"].position, [0.5, 0.0, 0.059])
    np.testing.assert_allclose(state.ee_position, [0.3, 0.0, 0.25])
    assert state.held == "hook"


def test_measured_size_within_tolerance_places_the_box_on_the_table(tmp_path: Path) -> None:
    parser = parser_for(
        tmp_path, {"objects": [{"name": "red_box", "position": [0.5, 0.0], "size": [0.05, 0.05, 0.12]}]}
    )
    assert parser.poses["red_box"].position[2] == pytest.approx(0.06)


def test_size_far_from_the_object_is_rejected(tmp_path: Path) -> None:
    with pytest.raises(
        SceneFileError, match=r"red_box: measured size \[0.05, 0.05, 0.2\] m differs .* by 0.082 m"
    ) as raised:
        parser_for(tmp_path, {"objects": [{"name": "red_box", "position": [0.5, 0.0], "size": [0.05, 0.05, 0.2]}]})
    assert "size_tolerance" in (raised.value.hint or "")


def test_tilted_object_needs_its_height(tmp_path: Path) -> None:
    lying = {"name": "red_box", "position": [0.5, 0.0], "quaternion": [0.7071068, 0, 0, 0.7071068]}
    with pytest.raises(SceneFileError, match="red_box: give its height"):
        parser_for(tmp_path, {"objects": [lying]})


@pytest.mark.parametrize(
    ("scene", "message"),
    [
        ({"objects": [{"name": "red_bx", "position": [0.5, 0]}]}, "unknown object 'red_bx'"),
        ({"objects": [{"name": "table", "position": [0, 0]}]}, "the table is the frame's origin"),
        (
            {"objects": [{"name": "red_box", "position": [0.5]}]},
            "objects.0.position: List should have at least 2 items",
        ),
        (
            {"objects": [{"name": "red_box", "position": [0.5, 0], "yaw": 1, "quaternion": [0, 0, 0, 1]}]},
            "give yaw or quaternion, not both",
        ),
        (
            {"objects": [{"name": "red_box", "position": [0.5, 0], "colour": "red"}]},
            "objects.0.colour: Extra inputs are not permitted",
        ),
        ({"objects": [{"name": "red_box", "position": [0.5, 0]}] * 2}, "objects listed more than once: red_box"),
        (
            {"objects": [{"name": "red_box", "position": [0.5, 0]}], "units": {"length": "inch"}},
            "units.length: Input should be 'm', 'cm' or 'mm'",
        ),
    ],
)
def test_bad_scene_files_are_explained(tmp_path: Path, scene: dict, message: str) -> None:
    with pytest.raises(SceneFileError, match=message):
        parser_for(tmp_path, scene)


def test_unknown_object_suggests_the_close_name(tmp_path: Path) -> None:
    with pytest.raises(SceneFileError) as raised:
        parser_for(tmp_path, {"objects": [{"name": "red_bx", "position": [0.5, 0]}]})
    assert (raised.value.hint or "").startswith("did you mean 'red_box'?")


def test_scene_must_match_the_tasks_objects(tmp_path: Path) -> None:
    parser = SceneFileParser(SceneFileOptions(path=EXAMPLE))
    with pytest.raises(SceneFileError, match="missing hook; not in the task cyan_box"):
        parser.parse(SceneObservation(object_names=("table", "rack", "hook", "blue_box", "yellow_box")))


def test_missing_file_and_bad_yaml(tmp_path: Path) -> None:
    with pytest.raises(SceneFileError, match="cannot read scene file .*nowhere.yaml"):
        SceneFileParser(SceneFileOptions(path=tmp_path / "nowhere.yaml"))
    bad = tmp_path / "bad.yaml"
    bad.write_text("objects: [\n", encoding="utf-8")
    with pytest.raises(SceneFileError, match="is not valid YAML/JSON"):
        SceneFileParser(SceneFileOptions(path=bad))
