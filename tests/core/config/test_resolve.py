"""Resolving run configurations: precedence, typed overrides, errors with their YAML paths."""

from __future__ import annotations

from pathlib import Path

import pytest

from t2m_core.config import RunConfig, check_config, parse_override, resolve_config
from t2m_core.errors import ConfigError
from t2m_core.registry import Registry
from tests.core.plugin_doubles import EveryKind, plugin, toy_simulator_spec


def write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_defaults_select_the_builtin_components() -> None:
    config = resolve_config()
    assert config == RunConfig()
    assert (config.task, config.seed) == ("task0", 0)
    assert (config.simulator.name, config.language_model.name, config.scene_parser.name) == (
        "mujoco",
        "local",
        "ground-truth",
    )
    assert (config.skills.name, config.feasibility_planner.name, config.task_planner.name) == ("tableenv", "policy-cem", "hybrid")
    assert config.run.closed_loop is True and config.output.video_fps == 30


def test_precedence_file_then_flag_then_set(tmp_path: Path) -> None:
    base = write(tmp_path, "base.yaml", "task: task1\nseed: 4\nsimulator: {name: pybullet, options: {gui: false}}\n")
    local = write(tmp_path, "local.yaml", "seed: 5\noutput: {video: false}\n")
    config = resolve_config(
        [base, local],
        flags={"seed": 6, "task": None, "llm": "gpt-4"},
        overrides=["seed=7", "output.video_fps=12"],
    )
    assert config.task == "task1"  # only the first file sets it
    assert config.seed == 7  # default 0 < base 4 < local 5 < --seed 6 < --set 7
    assert config.simulator.model_dump() == {"name": "pybullet", "options": {"gui": False}}  # deep-merged, kept
    assert config.language_model.name == "gpt-4"
    assert (config.output.video, config.output.video_fps) == (False, 12)


def test_later_files_deep_merge_over_earlier_ones(tmp_path: Path) -> None:
    first = write(tmp_path, "a.yaml", "simulator: {name: toysim, options: {timestep: 0.01, substeps: 4}}\n")
    second = write(tmp_path, "b.yaml", "simulator: {options: {substeps: 2}}\n")
    config = resolve_config([first, second])
    assert config.simulator.options == {"timestep": 0.01, "substeps": 2}


def test_flag_choosing_another_component_drops_the_old_options(tmp_path: Path) -> None:
    path = write(tmp_path, "c.yaml", "language_model: {name: local, options: {n_ctx: 4096}}\n")
    assert resolve_config([path], flags={"llm": "gpt-4"}).language_model.options == {}
    assert resolve_config([path], flags={"llm": "local"}).language_model.options == {"n_ctx": 4096}


def test_planner_flag_fills_a_null_block() -> None:
    config = resolve_config(flags={"planner": "hybrid"}, overrides=["task_planner.options.beta=0.3"])
    assert config.task_planner is not None
    assert config.task_planner.model_dump() == {"name": "hybrid", "options": {"beta": 0.3}}


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("seed=3", (("seed",), 3)),
        ("run.closed_loop=false", (("run", "closed_loop"), False)),
        ("simulator.options.size=[0.1, 0.2]", (("simulator", "options", "size"), [0.1, 0.2])),
        ("task=task3", (("task",), "task3")),
        ("skills=", (("skills",), None)),
        ("a.b=x: y: z", (("a", "b"), "x: y: z")),  # not YAML on its own: kept as text
    ],
)
def test_override_values_are_yaml_typed(text: str, expected: tuple) -> None:
    assert parse_override(text) == expected


@pytest.mark.parametrize("text", ["seed", "=3", "a..b=1"])
def test_malformed_override_is_rejected(text: str) -> None:
    with pytest.raises(ConfigError, match="invalid --set"):
        parse_override(text)


def test_override_through_a_scalar_is_rejected() -> None:
    with pytest.raises(ConfigError, match="seed is 0, not a mapping") as raised:
        resolve_config(overrides=["seed.value=1"])
    assert raised.value.hint == "set seed itself, e.g. --set seed=<value>"


def test_unknown_keys_are_rejected_with_path_and_source(tmp_path: Path) -> None:
    path = write(tmp_path, "typo.yaml", "simulator: {name: mujoco, optons: {}}\nrun: {closed_lop: true}\n")
    config, issues = check_config([path], overrides=["output.fps=10"])
    assert config is None
    by_path = {issue.path: issue for issue in issues}
    assert set(by_path) == {"simulator.optons", "run.closed_lop", "output.fps"}
    assert by_path["simulator.optons"].message == "unknown key; did you mean 'options'? (valid keys: name, options)"
    assert by_path["simulator.optons"].source == str(path)
    assert by_path["output.fps"].source == "--set"
    with pytest.raises(ConfigError) as raised:
        resolve_config([path])
    assert (
        f"simulator.optons: unknown key; did you mean 'options'? (valid keys: name, options) (from {path})"
        in raised.value.message
    )
    assert "2 problems" in raised.value.message


def test_wrong_types_and_missing_names_are_reported(tmp_path: Path) -> None:
    path = write(tmp_path, "bad.yaml", "seed: many\ntask_planner: {options: {}}\nscene_parser: {options: {}}\n")
    _, issues = check_config([path])
    assert {str(issue) for issue in issues} == {
        f"seed: Input should be a valid integer, unable to parse string as an integer (from {path})",
    }  # task_planner and scene_parser keep their default names


def test_yaml_syntax_error_names_line_and_column(tmp_path: Path) -> None:
    path = write(tmp_path, "broken.yaml", "task: task0\nsimulator: {name: mujoco\n")
    with pytest.raises(ConfigError, match=rf"{path}:3:1: invalid YAML"):
        resolve_config([path])


def test_non_mapping_file_and_missing_file_are_rejected(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="must be a mapping of keys, got list"):
        resolve_config([write(tmp_path, "list.yaml", "- task0\n")])
    with pytest.raises(ConfigError, match="cannot read config file .*absent.yaml: No such file"):
        resolve_config([tmp_path / "absent.yaml"])


def test_unknown_named_flag_is_rejected() -> None:
    with pytest.raises(ConfigError, match="unknown named flag 'simulator'"):
        resolve_config(flags={"simulator": "mujoco"})


@pytest.fixture
def toy_registry() -> Registry:
    registry = Registry()
    registry.register_plugin(EveryKind(), name="every-kind")
    return registry


def toy_components(*extra: str) -> list[str]:
    return [
        "simulator.name=toysim",
        "language_model.name=gpt-toy",
        "scene_parser.name=toy-parser",
        "skills.name=toy-skills",
        "feasibility_planner.name=toy-cem",
        "task_planner.name=toy-hybrid",
        *extra,
    ]


def test_plugin_options_are_validated_and_filled_in(toy_registry: Registry) -> None:
    config = resolve_config(overrides=toy_components("simulator.options.substeps=2"), registry=toy_registry)
    assert config.simulator.options == {"timestep": 0.002, "substeps": 2}
    assert config.language_model.model_dump() == {"name": "gpt-toy", "options": {}}  # alias kept as written


def test_plugin_option_errors_carry_their_yaml_path(toy_registry: Registry, tmp_path: Path) -> None:
    path = write(tmp_path, "sim.yaml", "simulator: {name: toysim, options: {timestep: -1, substep: 2}}\n")
    _, issues = check_config([path], overrides=toy_components()[1:], registry=toy_registry)
    assert [str(issue) for issue in issues] == [
        f"simulator.options.timestep: Input should be greater than 0 (from {path})",
        f"simulator.options.substep: unknown key; did you mean 'substeps'? (valid keys: timestep, substeps) (from {path})",
    ]


def test_unknown_component_name_suggests_the_registered_one(toy_registry: Registry) -> None:
    _, issues = check_config(flags={"sim": "toysm"}, overrides=toy_components()[1:], registry=toy_registry)
    (issue,) = issues
    assert (issue.path, issue.source) == ("simulator.name", "named flags")
    assert issue.message == "unknown simulator 'toysm'; did you mean 'toysim'? valid choices: toysim"


def test_null_blocks_are_not_looked_up(toy_registry: Registry) -> None:
    registry = Registry()
    registry.register_plugin(plugin(t2m_register_simulators=[toy_simulator_spec()]))
    _, issues = check_config(overrides=["simulator.name=toysim"], registry=registry)
    _, issues = check_config(overrides=["simulator.name=toysim", "task_planner=null"], registry=registry)
    # task_planner is null: not looked up; the others name components this registry lacks
    assert {issue.path for issue in issues} == {"language_model.name", "scene_parser.name", "skills.name", "feasibility_planner.name"}


def test_language_model_alias_implies_its_options() -> None:
    from pydantic import BaseModel, ConfigDict

    from t2m_core.plugin_specs import LanguageModelSpec, NamePrefix

    class HostedOptions(BaseModel):
        model_config = ConfigDict(extra="forbid")
        model: str = "big-1"
        timeout_s: float = 60.0

    hosted = LanguageModelSpec(
        name="hosted",
        aliases=("small",),
        factory="builtins:object",
        options=HostedOptions,
        summary="x",
        alias_options={"small": {"model": "small-2"}},
        name_prefixes=(NamePrefix("acme/", "model"),),
    )
    registry = Registry()
    registry.register_plugin(plugin(t2m_register_language_models=[hosted]), name="hosted")
    registry.register_plugin(EveryKind(), name="every-kind")
    others = ["simulator.name=toysim", "scene_parser.name=toy-parser", "skills.name=toy-skills", "feasibility_planner.name=toy-cem",
              "task_planner.name=toy-hybrid"]

    def language_model(llm: str, *overrides: str) -> dict:
        config = resolve_config(flags={"llm": llm}, overrides=[*others, *overrides], registry=registry)
        return config.language_model.model_dump()

    assert language_model("small") == {"name": "small", "options": {"model": "small-2", "timeout_s": 60.0}}
    assert language_model("small", "language_model.options.model=tiny")["options"]["model"] == "tiny"  # explicit wins
    assert language_model("acme/x9")["options"]["model"] == "acme/x9"


def test_language_model_spec_rejects_implied_options_that_do_not_exist() -> None:
    from pydantic import BaseModel, ConfigDict

    from t2m_core.plugin_specs import LanguageModelSpec, NamePrefix

    class HostedOptions(BaseModel):
        model_config = ConfigDict(extra="forbid")
        model: str = "big-1"

    common = {"name": "hosted", "factory": "builtins:object", "options": HostedOptions}
    with pytest.raises(ValueError, match=r"alias_options names \['tiny'\]"):
        LanguageModelSpec(**common, alias_options={"tiny": {"model": "t"}})
    with pytest.raises(ValueError, match=r"\['engine'\], which HostedOptions does not have"):
        LanguageModelSpec(**common, name_prefixes=(NamePrefix("acme/", "engine"),))


def test_unknown_task_is_reported_with_a_suggestion(toy_registry: Registry) -> None:
    _, issues = check_config(flags={"task": "tsk3"}, overrides=toy_components(), registry=toy_registry)
    assert [(issue.path, issue.source) for issue in issues] == [("task", "named flags")]
    assert issues[0].message.startswith("unknown task 'tsk3'; did you mean 'task3'?")
    assert resolve_config(flags={"task": "task3"}, overrides=toy_components(), registry=toy_registry).task == "task3"
