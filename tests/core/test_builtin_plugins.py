"""Every builtin plugin (entry points of the text2motion distribution) loads, conforms, and is import-light."""

from __future__ import annotations

import importlib
import importlib.metadata

import pytest

from t2m_core.registry import BUILTIN_DISTRIBUTION, ENTRY_POINT_GROUP
from t2m_core.testing import check_import_light, check_plugin_module

BUILTIN_ENTRY_POINTS = sorted(
    (entry_point.name, entry_point.value)
    for entry_point in importlib.metadata.distribution(BUILTIN_DISTRIBUTION).entry_points
    if entry_point.group == ENTRY_POINT_GROUP
)


def test_the_builtins_are_declared() -> None:
    assert {name for name, _ in BUILTIN_ENTRY_POINTS} >= {"mujoco", "llm_local", "litellm", "llm_replay", "scene_truth"}


@pytest.mark.parametrize(("name", "module"), BUILTIN_ENTRY_POINTS)
def test_builtin_hooks_module_conforms(name: str, module: str) -> None:
    # factories are imported too: a wrong "module:attribute" would otherwise surface only at run time
    specs = check_plugin_module(importlib.import_module(module), import_factories=True)
    assert all(spec.summary for spec in specs)


@pytest.mark.parametrize(("name", "module"), BUILTIN_ENTRY_POINTS)
def test_builtin_hooks_module_is_import_light(name: str, module: str) -> None:
    check_import_light(module)
