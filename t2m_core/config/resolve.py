"""Resolving a run configuration from its sources.

Precedence, lowest first: built-in defaults < config files (deep-merged, later files win) < named
flags (``--planner --sim --llm --task --seed``) < ``--set a.b=c`` overrides (values parsed as YAML).
A named flag that changes a component's name drops the options that earlier sources gave the previous
component: they belong to another plugin. Every problem is reported at once, each with its YAML path
(``simulator.options.timestep: ...``) and the source that set it.
"""

from __future__ import annotations

import copy
import difflib
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import yaml
from pydantic import BaseModel, ValidationError

from t2m_core.config.files import load_yaml_file
from t2m_core.config.models import COMPONENT_BLOCKS, ComponentConfig, RunConfig
from t2m_core.errors import ConfigError, PluginError, T2MError

if TYPE_CHECKING:
    from t2m_core.registry import Registry

NAMED_FLAGS: dict[str, tuple[str, ...]] = {
    "planner": ("task_planner", "name"),
    "sim": ("simulator", "name"),
    "llm": ("language_model", "name"),
    "task": ("task",),
    "seed": ("seed",),
}
"""CLI flag -> the config path it sets."""


@dataclass(frozen=True)
class ConfigIssue:
    """One problem: YAML path, what is wrong, and which source set the value."""

    path: str
    message: str
    source: str | None = None

    def __str__(self) -> str:
        origin = f" (from {self.source})" if self.source else ""
        return f"{self.path or '(top level)'}: {self.message}{origin}"


@dataclass(frozen=True)
class _Layer:
    source: str
    data: dict[str, Any]


def deep_merge(base: Mapping[str, Any], update: Mapping[str, Any]) -> dict[str, Any]:
    """``update`` merged into a copy of ``base``: mappings merge recursively, anything else replaces."""
    merged = copy.deepcopy(dict(base))
    for key, value in update.items():
        if isinstance(value, Mapping) and isinstance(merged.get(key), Mapping):
            merged[key] = deep_merge(merged[key], value)
        else:
            merged[key] = copy.deepcopy(value)
    return merged


def parse_override(text: str) -> tuple[tuple[str, ...], Any]:
    """``"a.b=c"`` -> ``(("a", "b"), c)`` with ``c`` parsed as YAML (``0.5``, ``true``, ``[1, 2]``, ``null``).

    Raises:
        ConfigError: no ``=``, or an empty key segment.
    """
    key, separator, raw_value = text.partition("=")
    path = tuple(part.strip() for part in key.split("."))
    if not separator or not all(path):
        raise ConfigError(f"invalid --set {text!r}", hint="write it as --set dotted.key=value, e.g. --set seed=3")
    try:
        value = yaml.safe_load(raw_value) if raw_value.strip() else None
    except yaml.YAMLError:
        value = raw_value  # not valid YAML on its own (e.g. "a: b"): keep the literal text
    return path, value


def _nested(path: Sequence[str], value: Any) -> dict[str, Any]:
    data: Any = value
    for part in reversed(path):
        data = {part: data}
    return data


def resolve_config(
    files: Iterable[Path] = (),
    *,
    flags: Mapping[str, Any] | None = None,
    overrides: Iterable[str] = (),
    registry: Registry | None = None,
) -> RunConfig:
    """The fully resolved run configuration.

    Args:
        files: config files, merged in order (later wins).
        flags: named flags by name (``{"sim": "pybullet", "seed": 3}``); ``None`` values are ignored.
        overrides: ``"a.b=c"`` strings, applied last, in order.
        registry: when given, the references are checked too: component names must be registered
            (their options are validated against, and filled in from, each plugin's options model)
            and the task must exist.

    Raises:
        ConfigError: listing every problem, one ``path: message (from source)`` line each.
    """
    config, issues = check_config(files, flags=flags, overrides=overrides, registry=registry)
    if issues:
        lines = "\n".join(f"  {issue}" for issue in issues)
        raise ConfigError(
            f"invalid run configuration ({len(issues)} problem{'s' if len(issues) > 1 else ''}):\n{lines}",
            hint="fix the keys named above; `t2m config schema` lists every valid key",
        )
    assert config is not None
    return config


def check_config(
    files: Iterable[Path] = (),
    *,
    flags: Mapping[str, Any] | None = None,
    overrides: Iterable[str] = (),
    registry: Registry | None = None,
) -> tuple[RunConfig | None, list[ConfigIssue]]:
    """Like :func:`resolve_config`, but returns ``(config or None, every issue)`` instead of raising.

    Unreadable files and malformed ``--set`` strings still raise :class:`ConfigError` at once.
    """
    layers = [_Layer("defaults", RunConfig().model_dump(mode="json"))]
    layers += [_Layer(str(path), load_yaml_file(Path(path))) for path in files]
    merged: dict[str, Any] = {}
    for layer in layers:
        merged = deep_merge(merged, layer.data)

    flag_layer = _Layer("named flags", {})
    for flag, value in (flags or {}).items():
        if value is None:
            continue
        if flag not in NAMED_FLAGS:
            raise ConfigError(f"unknown named flag {flag!r}", hint=f"valid flags: {', '.join(NAMED_FLAGS)}")
        path = NAMED_FLAGS[flag]
        if path[-1] == "name":
            merged = _select_component(merged, path[0], value)
        flag_layer.data.update(deep_merge(flag_layer.data, _nested(path, value)))
    merged = deep_merge(merged, flag_layer.data)
    layers.append(flag_layer)

    set_layer = _Layer("--set", {})
    for text in overrides:
        path, value = parse_override(text)
        merged = _set_path(merged, path, value, text)
        set_layer = _Layer("--set", deep_merge(set_layer.data, _nested(path, value)))
    layers.append(set_layer)

    try:
        config: RunConfig | None = RunConfig.model_validate(merged)
        issues: list[ConfigIssue] = []
    except ValidationError as error:
        config, issues = None, [_issue_from_pydantic(issue, (), RunConfig, layers) for issue in error.errors()]
    if registry is None:
        return config, issues
    # references are checked even when the structure has problems, so one pass reports everything
    resolved_blocks, reference_issues = _check_components(merged, registry, layers)
    if isinstance(merged.get("task"), str):
        reference_issues += _check_task(merged["task"], layers)
    issues += reference_issues
    if issues or config is None:
        return None, issues
    return RunConfig.model_validate({**merged, **resolved_blocks}), []


def _check_task(task: str, layers: Sequence[_Layer]) -> list[ConfigIssue]:
    from t2m_core.tasks.loader import load_task

    try:
        load_task(task)
    except T2MError as error:
        message = f"{error.message}; {error.hint}" if error.hint else error.message
        return [ConfigIssue("task", message, _source_of(("task",), layers))]
    return []


def _select_component(merged: dict[str, Any], block: str, name: str) -> dict[str, Any]:
    """Drop the previous component's options when a flag picks another component for ``block``."""
    current = merged.get(block)
    if isinstance(current, Mapping) and current.get("name") not in (None, name):
        merged = dict(merged)
        merged[block] = {key: value for key, value in current.items() if key != "options"}
    return merged


def _set_path(data: dict[str, Any], path: Sequence[str], value: Any, text: str) -> dict[str, Any]:
    result = copy.deepcopy(data)
    node = result
    for depth, part in enumerate(path[:-1]):
        child = node.get(part)
        if child is None:
            child = node[part] = {}
        if not isinstance(child, dict):
            where = ".".join(path[: depth + 1])
            raise ConfigError(
                f"cannot apply --set {text!r}: {where} is {child!r}, not a mapping",
                hint=f"set {where} itself, e.g. --set {where}=<value>",
            )
        node = child
    node[path[-1]] = value
    return result


def _check_components(
    merged: Mapping[str, Any], registry: Registry, layers: Sequence[_Layer]
) -> tuple[dict[str, Any], list[ConfigIssue]]:
    """Each well-formed component block's name and options checked against the registry.

    Returns the blocks with their options filled in from the plugins' models, and the issues found.
    """
    resolved: dict[str, Any] = {}
    issues: list[ConfigIssue] = []
    for block, kind in COMPONENT_BLOCKS.items():
        if merged.get(block) is None:
            continue
        try:
            component = ComponentConfig.model_validate(merged[block])
        except ValidationError:
            continue  # already reported by the structural check
        try:
            canonical, implied_options = _select(kind, component.name, component.options, registry)
            spec = registry.get(kind, canonical)
        except PluginError as error:
            message = f"{error.message}; {error.hint}" if error.hint else error.message
            issues.append(ConfigIssue(f"{block}.name", message, _source_of((block, "name"), layers)))
            continue
        try:
            options = spec.options.model_validate(implied_options)
        except ValidationError as error:
            prefix = (block, "options")
            issues.extend(_issue_from_pydantic(issue, prefix, spec.options, layers) for issue in error.errors())
            continue
        resolved[block] = {"name": component.name, "options": options.model_dump(mode="json")}
    return resolved, issues


def _select(kind: str, name: str, options: dict[str, Any], registry: Registry) -> tuple[str, dict[str, Any]]:
    """The canonical component name and the options that ``name`` implies plus the explicit ones.

    Language models also resolve names the registry does not list itself: aliases that carry options
    (``gpt-4`` -> litellm with ``model: gpt-4``) and provider prefixes (``ollama/llama3``).
    """
    if kind == "language_model":
        from t2m_core.language.selection import resolve_language_model

        return resolve_language_model(name, options, registry)
    return name, options


def _issue_from_pydantic(
    issue: Mapping[str, Any], prefix: tuple[str, ...], model: type[BaseModel], layers: Sequence[_Layer]
) -> ConfigIssue:
    loc = tuple(str(part) for part in issue["loc"])
    path = (*prefix, *loc)
    message = issue["msg"]
    if issue["type"] == "extra_forbidden":
        valid = _valid_keys(model, loc[:-1])
        close = difflib.get_close_matches(loc[-1], valid, n=1)
        message = "unknown key" + (f"; did you mean {close[0]!r}?" if close else "")
        message += f" (valid keys: {', '.join(valid)})" if valid else ""
    elif issue["type"] == "missing":
        message = "required key is missing"
    return ConfigIssue(_format_path(path), message, _source_of(path, layers))


def _valid_keys(model: type[BaseModel], loc: Sequence[str]) -> list[str]:
    """Field names of the (nested) model at ``loc``, or ``[]`` when it is not a model."""
    current: Any = model
    for part in loc:
        field = current.model_fields.get(part) if isinstance(current, type) and issubclass(current, BaseModel) else None
        if field is None:
            return []
        current = _model_in(field.annotation)
    if isinstance(current, type) and issubclass(current, BaseModel):
        return list(current.model_fields)
    return []


def _model_in(annotation: Any) -> Any:
    """The pydantic model inside ``annotation`` (``Model``, ``Model | None``), else ``None``."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    for argument in getattr(annotation, "__args__", ()):
        if (found := _model_in(argument)) is not None:
            return found
    return None


def _format_path(path: Sequence[str]) -> str:
    return "".join(f"[{part}]" if part.isdigit() else f".{part}" for part in path).lstrip(".")


def _source_of(path: Sequence[str], layers: Sequence[_Layer]) -> str | None:
    """The latest source that sets the longest prefix of ``path`` (a missing key is blamed on the
    source that wrote its parent; an item of a list on the source that wrote the list)."""
    for depth in range(len(path), 0, -1):
        for layer in reversed(layers):
            node: Any = layer.data
            for part in path[:depth]:
                if not isinstance(node, Mapping) or part not in node:
                    break
                node = node[part]
            else:
                return layer.source
    return None
