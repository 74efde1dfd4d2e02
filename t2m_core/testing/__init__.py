"""The testing kit for t2m plugins: conformance checks and pytest fixtures.

Every builtin plugin passes these checks, and a third-party author runs them in their own tests::

    from t2m_core.testing import check_plugin_spec, check_scene_parser

    def test_my_parser_conforms():
        check_scene_parser(MyParser(MyOptions()), sample_observation())

The pytest fixtures (``t2m_registry``, ``t2m_plugin``, ``t2m_fake_distribution``) are available in
every test session once t2m is installed (pytest11 entry point :mod:`t2m_core.testing.fixtures`).

Checks are imported lazily on first attribute access, so importing this package stays cheap.
"""

from __future__ import annotations

import importlib
from typing import Any

_LAZY: dict[str, str] = {
    "check_simulator": "t2m_core.testing.simulator",
    "check_language_model": "t2m_core.testing.language_model",
    "check_skill": "t2m_core.testing.skill",
    "check_feasibility_planner": "t2m_core.testing.feasibility",
    "check_task_planner": "t2m_core.testing.task_planner",
    "sample_skill_states": "t2m_core.testing.skill",
    "check_scene_parser": "t2m_core.testing.scene_parser",
    "sample_observation": "t2m_core.testing.scene_parser",
    "check_plugin_spec": "t2m_core.testing.plugins",
    "check_plugin_module": "t2m_core.testing.plugins",
    "check_import_light": "t2m_core.testing.plugins",
    "HEAVY_MODULES": "t2m_core.testing.plugins",
    "write_fake_distribution": "t2m_core.testing.distributions",
    "FakeDistribution": "t2m_core.testing.distributions",
}

__all__ = [
    "HEAVY_MODULES",
    "FakeDistribution",
    "check_feasibility_planner",
    "check_import_light",
    "check_language_model",
    "check_plugin_module",
    "check_plugin_spec",
    "check_scene_parser",
    "check_task_planner",
    "check_simulator",
    "check_skill",
    "sample_observation",
    "sample_skill_states",
    "write_fake_distribution",
]


def __getattr__(name: str) -> Any:
    if name not in _LAZY:
        raise AttributeError(f"module 't2m_core.testing' has no attribute {name!r}")
    value = getattr(importlib.import_module(_LAZY[name]), name)
    globals()[name] = value  # cache: later look-ups skip __getattr__
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY})
