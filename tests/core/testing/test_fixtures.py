"""The pytest fixtures clean up after a test, even one that fails."""

from __future__ import annotations

import pytest

pytest_plugins = ["pytester"]

INNER_TESTS = """
import sys
from types import SimpleNamespace

from t2m_core.hookspecs import hookimpl
from t2m_core.plugin_specs import SceneParserSpec
from t2m_core.registry import get_registry

@hookimpl
def t2m_register_scene_parsers():
    return [SceneParserSpec(name="throwaway", factory="builtins:object", summary="x")]

THROWAWAY = SimpleNamespace(t2m_register_scene_parsers=t2m_register_scene_parsers)


def test_1_registers_then_fails(t2m_plugin):
    t2m_plugin(THROWAWAY, name="throwaway")
    assert "throwaway" in get_registry().names("scene_parser")
    raise RuntimeError("fails on purpose")


def test_2_fake_distribution_then_fails(t2m_fake_distribution):
    t2m_fake_distribution("gone-t2m", entry_points={"gone": "gone_t2m"}, files={"gone_t2m.py": "x = 1"})
    assert "gone" in [record.name for record in get_registry().plugins]
    import gone_t2m
    raise RuntimeError("fails on purpose")


def test_3_everything_was_cleaned_up():
    registry = get_registry()
    assert "throwaway" not in registry.names("scene_parser")
    assert "gone" not in [record.name for record in registry.plugins]
    assert "gone_t2m" not in sys.modules
    assert not any("site-packages" in path and "pytest-of" in path for path in sys.path)
"""


def test_fixtures_clean_up_after_failing_tests(pytester: pytest.Pytester) -> None:
    pytester.makepyfile(test_inner=INNER_TESTS)
    result = pytester.runpytest_inprocess("-p", "no:cacheprovider")
    result.assert_outcomes(passed=1, failed=2)
