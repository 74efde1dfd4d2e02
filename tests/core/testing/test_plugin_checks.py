"""The plugin conformance checks catch the mistakes they are meant to catch."""

from __future__ import annotations

from types import SimpleNamespace

import pytest
from pydantic import BaseModel

from t2m_core.hookspecs import hookimpl
from t2m_core.plugin_specs import SimulatorSpec
from t2m_core.testing import check_import_light, check_plugin_module, check_plugin_spec
from tests.core.plugin_doubles import ToySimOptions, toy_simulator_spec


class LaxOptions(BaseModel):
    """Accepts unknown keys (the mistake under test)."""

    timestep: float = 0.002


def test_a_good_spec_passes() -> None:
    check_plugin_spec(toy_simulator_spec())


@pytest.mark.parametrize(
    ("spec", "problem"),
    [
        (
            SimulatorSpec(name="MySim", factory=dict, options=ToySimOptions, summary="x"),
            "invalid name or alias 'MySim'",
        ),
        (
            SimulatorSpec(name="sim", aliases=("sim",), factory=dict, options=ToySimOptions, summary="x"),
            "an alias repeats the name",
        ),
        (
            SimulatorSpec(name="sim", factory=dict, options=ToySimOptions, summary=""),
            "summary must be one non-empty line",
        ),
        (SimulatorSpec(name="sim", factory=dict, options=LaxOptions, summary="x"), "must reject unknown keys"),
        (
            SimulatorSpec(name="sim", factory="my_package.sim", options=ToySimOptions, summary="x"),
            "must look like 'module:attribute'",
        ),
    ],
)
def test_bad_specs_are_named(spec: SimulatorSpec, problem: str) -> None:
    with pytest.raises(AssertionError, match=problem):
        check_plugin_spec(spec)


def test_unimportable_factory_fails_the_check() -> None:
    spec = SimulatorSpec(name="sim", factory="t2m_no_such_module:Sim", options=ToySimOptions, summary="x")
    with pytest.raises(ModuleNotFoundError):
        check_plugin_spec(spec)
    check_plugin_spec(spec, import_factory=False)


def test_plugin_module_without_components_or_with_an_unmarked_hook_fails() -> None:
    with pytest.raises(AssertionError, match="registers no component"):
        check_plugin_module(SimpleNamespace(__name__="empty"))  # type: ignore[arg-type]
    unmarked = SimpleNamespace(
        __name__="unmarked",
        t2m_core=__import__("t2m_core"),
        t2m_register_simulator=hookimpl(lambda: []),  # noqa: PIE807 - hookimpl marks the function
    )  # an imported t2m_* module is fine; a misspelt hook is not
    with pytest.raises(AssertionError, match="not t2m hooks: t2m_register_simulator"):
        check_plugin_module(unmarked)  # type: ignore[arg-type]


def test_import_light_check_sees_heavy_imports(tmp_path, monkeypatch) -> None:
    (tmp_path / "heavy_hooks.py").write_text("import json\nimport email.parser\n", encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))
    check_import_light("heavy_hooks")
    with pytest.raises(AssertionError, match="importing heavy_hooks also imports email.parser"):
        check_import_light("heavy_hooks", heavy=("email.parser", "torch"))
