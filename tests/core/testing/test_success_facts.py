"""The conformance checks judge a reported success by the poses, not by the backend's own verdict."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from t2m_core.domain.state import GeometricState, ObjectPose
from t2m_core.tasks import load_task
from t2m_core.testing import check_simulator
from t2m_core.testing.success_facts import success_problems
from tests.core.plugin_doubles import ScriptedSimulator

TILTED = np.array([np.sin(0.2), 0.0, 0.0, np.cos(0.2)])  # 23° about x


def scene(**poses: tuple[tuple[float, float, float], np.ndarray | None]) -> GeometricState:
    """A state with the table, the rack at (0.5, 0.3) and the given objects; ``held`` via ``held=``."""
    objects = {"table": ObjectPose(np.zeros(3)), "rack": ObjectPose(np.array([0.5, 0.3, 0.16]))}
    for name, (position, quaternion) in poses.items():
        objects[name] = ObjectPose(np.array(position), np.array([0, 0, 0, 1.0]) if quaternion is None else quaternion)
    return GeometricState(objects=objects)


def held(state: GeometricState, name: str | None) -> GeometricState:
    return dataclasses.replace(state, held=name)


# red_box is 0.118 m tall: resting on the table its centre is at 0.059, on the rack at 0.219
ON_TABLE = ((0.5, -0.2, 0.059), None)
ON_RACK = ((0.52, 0.28, 0.219), None)


def test_place_on_the_rack_is_confirmed_only_when_the_box_rests_on_it():
    start = held(scene(red_box=((0.4, 0.0, 0.34), None)), "red_box")
    assert success_problems("place", start, scene(red_box=ON_RACK), ["red_box", "rack"]) == []
    fell_off = success_problems("place", start, scene(red_box=ON_TABLE), ["red_box", "rack"])
    assert any("not resting" in problem for problem in fell_off)
    beside = success_problems("place", start, scene(red_box=((0.75, 0.3, 0.219), None)), ["red_box", "rack"])
    assert any("not over rack" in problem for problem in beside)
    tipped = success_problems("place", start, scene(red_box=(ON_RACK[0], TILTED)), ["red_box", "rack"])
    assert any("not upright" in problem for problem in tipped)
    still_held = success_problems("place", start, held(scene(red_box=ON_RACK), "red_box"), ["red_box", "rack"])
    assert any("still held" in problem for problem in still_held)


def test_pick_is_confirmed_only_when_the_object_is_held_and_lifted():
    start = scene(red_box=ON_TABLE)
    lifted = held(scene(red_box=((0.4, 0.0, 0.34), None)), "red_box")
    assert success_problems("pick", start, lifted, ["red_box"]) == []
    assert success_problems("pick", start, start, ["red_box"]) != []
    assert success_problems("pick", start, held(start, "red_box"), ["red_box"]) != []  # held but on the table


def test_pull_and_push_are_confirmed_only_when_the_box_moved_the_right_way():
    far = scene(hook=((0.4, 0.0, 0.34), None), red_box=((0.75, -0.2, 0.059), None))
    near = scene(hook=((0.4, 0.0, 0.34), None), red_box=((0.55, -0.2, 0.059), None))
    assert success_problems("pull", held(far, "hook"), held(near, "hook"), ["red_box", "hook"]) == []
    assert any("not pulled" in p for p in success_problems("pull", held(far, "hook"), held(far, "hook"), ["red_box", "hook"]))

    under = scene(hook=((0.3, 0.0, 0.34), None), red_box=((0.5, 0.3, 0.059), None))
    before = scene(hook=((0.3, 0.0, 0.34), None), red_box=((0.35, 0.2, 0.059), None))
    assert success_problems("push", held(before, "hook"), held(under, "hook"), ["red_box", "hook", "rack"]) == []
    short = success_problems("push", held(before, "hook"), held(before, "hook"), ["red_box", "hook", "rack"])
    assert any("not pushed" in p for p in short) and any("does not overlap" in p for p in short)


def test_check_simulator_rejects_a_backend_that_reports_false_successes():
    assert load_task("task0").reference_skeleton[0].name == "pick"
    with pytest.raises(AssertionError, match=r"pick\('yellow_box',\): reported success, but yellow_box is not held"):
        check_simulator(lambda: ScriptedSimulator(success=True), task_ids=("task0",), seeds=(0,))
