"""The registry's policy: registration, aliases, duplicates, unknown names, failures, discovery."""

from __future__ import annotations

import pytest

from t2m_core.errors import ConfigError, PluginError
from t2m_core.hookspecs import REGISTRATION_HOOKS, hookimpl
from t2m_core.plugin_specs import SceneParserSpec, SimulatorSpec
from t2m_core.registry import KINDS, Registry, get_registry
from tests.core.plugin_doubles import EveryKind, ToySimOptions, ToySimulator, plugin, toy_simulator_spec

BROKEN_HOOKS = """
raise ImportError("needs the acme camera driver")
"""

GOOD_HOOKS = """
from t2m_core.hookspecs import hookimpl
from t2m_core.plugin_specs import SceneParserSpec

@hookimpl
def t2m_register_scene_parsers():
    return [SceneParserSpec(name="acme-camera", factory="builtins:object", summary="Acme RGB-D parser")]
"""


def test_every_kind_registers_and_resolves(t2m_registry: Registry) -> None:
    t2m_registry.register_plugin(EveryKind(), name="every-kind")
    assert {entry.kind for entry in t2m_registry.components()} == set(KINDS) == set(REGISTRATION_HOOKS)
    assert t2m_registry.names("language_model") == ["toy-llm"]
    assert t2m_registry.get("language_model", "gpt-toy").name == "toy-llm"  # alias
    assert t2m_registry.entry("task_planner", "toy-hybrid").plugin.provider == "runtime"


def test_create_validates_options_and_calls_the_factory(t2m_registry: Registry) -> None:
    t2m_registry.register_plugin(plugin(t2m_register_simulators=[toy_simulator_spec()]), name="toy")
    simulator = t2m_registry.create("simulator", "toysim", {"timestep": 0.01})
    assert isinstance(simulator, ToySimulator)
    assert simulator.options == ToySimOptions(timestep=0.01, substeps=8)


def test_invalid_options_name_the_field(t2m_registry: Registry) -> None:
    t2m_registry.register_plugin(plugin(t2m_register_simulators=[toy_simulator_spec()]), name="toy")
    with pytest.raises(ConfigError) as raised:
        t2m_registry.create("simulator", "toysim", {"timestep": -1.0, "colour": "red"})
    assert "timestep: Input should be greater than 0" in raised.value.message
    assert "colour: Extra inputs are not permitted" in raised.value.message
    assert "timestep, substeps" in (raised.value.hint or "")


def test_unknown_name_lists_choices_and_suggests(t2m_registry: Registry) -> None:
    t2m_registry.register_plugin(plugin(t2m_register_simulators=[toy_simulator_spec(), toy_simulator_spec("bullet")]))
    with pytest.raises(PluginError) as raised:
        t2m_registry.get("simulator", "toysm")
    assert raised.value.message == "unknown simulator 'toysm'"
    assert raised.value.hint == "did you mean 'toysim'? valid choices: bullet, toysim"


def test_unknown_kind_is_rejected(t2m_registry: Registry) -> None:
    with pytest.raises(PluginError, match="unknown component kind 'simulators'") as raised:
        t2m_registry.names("simulators")
    assert "did you mean 'simulator'?" in (raised.value.hint or "")


def test_duplicate_name_names_both_providers(t2m_registry: Registry) -> None:
    t2m_registry.register_plugin(
        plugin(t2m_register_simulators=[toy_simulator_spec()]), name="a", provider="acme-sim", version="1.2"
    )
    t2m_registry.register_plugin(plugin(t2m_register_simulators=[toy_simulator_spec()]), name="b", provider="other-sim")
    with pytest.raises(PluginError) as raised:
        t2m_registry.components()
    assert "simulator name 'toysim' is provided twice" in raised.value.message
    assert "acme-sim 1.2 (plugin 'a'" in raised.value.message
    assert "other-sim (plugin 'b'" in raised.value.message


def test_alias_clashing_with_another_name_is_a_duplicate(t2m_registry: Registry) -> None:
    t2m_registry.register_plugin(plugin(t2m_register_simulators=[toy_simulator_spec("mujoco")]), name="a")
    t2m_registry.register_plugin(
        plugin(t2m_register_simulators=[toy_simulator_spec("fast", aliases=("mujoco",))]), name="b"
    )
    with pytest.raises(PluginError, match="'mujoco' is provided twice"):
        t2m_registry.get("simulator", "fast")


def test_same_name_in_different_kinds_is_allowed(t2m_registry: Registry) -> None:
    t2m_registry.register_plugin(
        plugin(
            t2m_register_simulators=[toy_simulator_spec("acme")],
            t2m_register_scene_parsers=[SceneParserSpec(name="acme", factory="builtins:object", summary="x")],
        )
    )
    assert t2m_registry.get("simulator", "acme").kind == "simulator"
    assert t2m_registry.get("scene_parser", "acme").kind == "scene_parser"


def test_failing_hook_marks_only_its_plugin_failed(t2m_registry: Registry) -> None:
    class Exploding:
        @hookimpl
        def t2m_register_simulators(self) -> list[SimulatorSpec]:
            raise RuntimeError("license server unreachable")

    t2m_registry.register_plugin(Exploding(), name="exploding")
    t2m_registry.register_plugin(plugin(t2m_register_simulators=[toy_simulator_spec()]), name="good")
    assert t2m_registry.names("simulator") == ["toysim"]
    (failed,) = t2m_registry.failed_plugins()
    assert failed.name == "exploding"
    assert failed.status == "failed: RuntimeError: license server unreachable"


def test_wrong_return_type_marks_the_plugin_failed(t2m_registry: Registry) -> None:
    # a scene parser spec returned from the simulator hook is a plugin bug, reported as such
    wrong = SceneParserSpec(name="p", factory="builtins:object", summary="x")
    t2m_registry.register_plugin(plugin(t2m_register_simulators=[wrong]), name="confused")
    assert t2m_registry.names("simulator") == []
    assert t2m_registry.failed_plugins()[0].status.startswith(
        "failed: TypeError: t2m_register_simulators must return a list of SimulatorSpec"
    )


def test_factory_that_cannot_be_imported_is_a_plugin_error(t2m_registry: Registry) -> None:
    spec = SimulatorSpec(name="ghost", factory="t2m_no_such_module.sim:Sim", summary="x")
    t2m_registry.register_plugin(plugin(t2m_register_simulators=[spec]), name="ghost", provider="ghost-dist")
    with pytest.raises(
        PluginError, match=r"cannot load the factory of simulator 'ghost'.*ModuleNotFoundError"
    ) as raised:
        t2m_registry.create("simulator", "ghost")
    assert raised.value.hint == "reinstall ghost-dist with its dependencies"


def test_unregister_removes_the_components(t2m_registry: Registry) -> None:
    t2m_registry.register_plugin(plugin(t2m_register_simulators=[toy_simulator_spec()]), name="toy")
    t2m_registry.unregister_plugin("toy")
    assert t2m_registry.names("simulator") == []
    assert t2m_registry.plugins == []


def test_registering_the_same_plugin_name_twice_is_rejected(t2m_registry: Registry) -> None:
    t2m_registry.register_plugin(plugin(), name="toy", provider="first")
    with pytest.raises(PluginError, match="already registered \\(from first\\)"):
        t2m_registry.register_plugin(plugin(), name="toy")


def test_discovery_from_an_installed_distribution(t2m_fake_distribution) -> None:
    t2m_fake_distribution(
        "acme-t2m",
        version="2.5.0",
        entry_points={"acme": "acme_t2m.hooks"},
        files={"acme_t2m/__init__.py": "", "acme_t2m/hooks.py": GOOD_HOOKS},
    )
    entry = get_registry().entry("scene_parser", "acme-camera")
    assert (entry.plugin.provider, entry.plugin.version, entry.plugin.builtin) == ("acme-t2m", "2.5.0", False)
    assert entry.plugin.name == "acme" and entry.plugin.module == "acme_t2m.hooks"


def test_broken_distribution_is_listed_as_failed_and_others_still_work(t2m_fake_distribution) -> None:
    t2m_fake_distribution("broken-t2m", entry_points={"broken": "broken_t2m"}, files={"broken_t2m.py": BROKEN_HOOKS})
    t2m_fake_distribution(
        "acme-t2m",
        entry_points={"acme": "acme_t2m.hooks"},
        files={"acme_t2m/__init__.py": "", "acme_t2m/hooks.py": GOOD_HOOKS},
    )
    registry = get_registry()
    broken = next(record for record in registry.plugins if record.name == "broken")
    assert broken.status == "failed: ImportError: needs the acme camera driver"
    assert broken.provider == "broken-t2m"
    assert "acme-camera" in registry.names("scene_parser")
    assert "ground-truth" in registry.names("scene_parser")  # builtins unaffected


def test_autoload_switch_keeps_builtins_and_skips_third_party(t2m_fake_distribution, monkeypatch) -> None:
    t2m_fake_distribution(
        "acme-t2m",
        entry_points={"acme": "acme_t2m.hooks"},
        files={"acme_t2m/__init__.py": "", "acme_t2m/hooks.py": GOOD_HOOKS},
    )
    monkeypatch.setenv("T2M_DISABLE_PLUGIN_AUTOLOAD", "1")
    registry = Registry.from_entry_points()
    assert "acme-camera" not in registry.names("scene_parser")
    truth = registry.entry("scene_parser", "ground-truth").plugin
    assert (truth.provider, truth.builtin) == ("text2motion", True)
    assert all(record.builtin for record in registry.plugins)


def test_t2m_plugins_loads_modules_by_name(t2m_fake_distribution, monkeypatch) -> None:
    # installed without an entry point: only T2M_PLUGINS can bring it in
    t2m_fake_distribution(
        "acme-t2m", version="0.3", files={"acme_t2m/__init__.py": "", "acme_t2m/hooks.py": GOOD_HOOKS}
    )
    monkeypatch.setenv("T2M_DISABLE_PLUGIN_AUTOLOAD", "1")
    monkeypatch.setenv("T2M_PLUGINS", "acme_t2m.hooks, t2m_missing_plugin")
    registry = Registry.from_entry_points()
    entry = registry.entry("scene_parser", "acme-camera")
    assert (entry.plugin.provider, entry.plugin.version) == ("acme-t2m", "0.3")
    missing = next(record for record in registry.plugins if record.name == "t2m_missing_plugin")
    assert missing.status == "failed: ModuleNotFoundError: No module named 't2m_missing_plugin'"
    assert missing.provider == "T2M_PLUGINS"


def test_same_entry_point_name_from_two_distributions_is_a_duplicate_not_a_failure(t2m_fake_distribution) -> None:
    for distribution in ("acme-t2m", "other-t2m"):
        package = distribution.replace("-", "_")
        t2m_fake_distribution(
            distribution,
            entry_points={"camera": f"{package}.hooks"},
            files={f"{package}/__init__.py": "", f"{package}/hooks.py": GOOD_HOOKS},
        )
    registry = get_registry()
    with pytest.raises(PluginError) as raised:
        registry.names("scene_parser")
    assert "'acme-camera' is provided twice" in raised.value.message
    # whichever is found second is registered as "<provider>:camera"
    assert "acme-t2m 1.0.0 (plugin '" in raised.value.message and "other-t2m 1.0.0 (plugin '" in raised.value.message
    names = {record.name for record in registry.plugins} & {"camera", "acme-t2m:camera", "other-t2m:camera"}
    assert len(names) == 2 and "camera" in names


def test_t2m_plugins_naming_an_entry_point_module_loads_it_once(monkeypatch) -> None:
    monkeypatch.setenv("T2M_PLUGINS", "t2m_scene_truth.hooks")
    registry = Registry.from_entry_points()
    assert registry.names("scene_parser").count("ground-truth") == 1
    assert [record.name for record in registry.plugins].count("scene_truth") == 1
    assert not any(record.name == "t2m_scene_truth.hooks" for record in registry.plugins)
