"""Conformance checks for a plugin's hooks module and the specs it registers."""

from __future__ import annotations

import inspect
import json
import os
import re
import subprocess
import sys
from types import ModuleType

from pydantic import BaseModel

from t2m_core import hookspecs
from t2m_core.plugin_specs import SPEC_TYPES, ComponentSpec

HEAVY_MODULES: tuple[str, ...] = ("torch", "mujoco", "pybullet", "llama_cpp", "litellm")
"""Modules a hooks module must not import: they would slow down ``t2m --help`` and ``list-plugins``."""

NAME_PATTERN = re.compile(r"^[a-z0-9][a-z0-9._/-]*$")
"""Component names and aliases: lowercase, digits, ``-``, ``_``, ``.``; ``/`` for provider/model names."""


def check_plugin_spec(spec: ComponentSpec, *, import_factory: bool = True) -> None:
    """Assert that ``spec`` is well formed.

    Checks: a known spec type; lowercase name and aliases that differ from the name; a one-line
    summary; an options model that is a pydantic model rejecting unknown keys; a factory given as
    ``"module:attribute"`` (or a callable) that resolves to a callable when ``import_factory``.

    Raises:
        AssertionError: naming the first problem found.
    """
    assert isinstance(spec, ComponentSpec) and type(spec) in SPEC_TYPES.values(), (
        f"{spec!r} is not one of the spec types {', '.join(t.__name__ for t in SPEC_TYPES.values())}"
    )
    label = f"{type(spec).__name__} {spec.name!r}"
    for name in (spec.name, *spec.aliases):
        assert isinstance(name, str) and NAME_PATTERN.match(name), f"{label}: invalid name or alias {name!r}"
    assert spec.name not in spec.aliases, f"{label}: an alias repeats the name"
    assert len(set(spec.aliases)) == len(spec.aliases), f"{label}: repeated aliases"
    assert spec.summary.strip() and "\n" not in spec.summary, f"{label}: summary must be one non-empty line"
    assert isinstance(spec.options, type) and issubclass(spec.options, BaseModel), (
        f"{label}: options must be a pydantic model class"
    )
    assert spec.options.model_config.get("extra") == "forbid", (
        f"{label}: options model {spec.options.__name__} must reject unknown keys: model_config = ConfigDict(extra='forbid')"
    )
    if isinstance(spec.factory, str):
        module_name, _, attribute = spec.factory.partition(":")
        assert module_name and attribute, f"{label}: factory must look like 'module:attribute', got {spec.factory!r}"
    if import_factory:
        assert callable(spec.load_factory()), f"{label}: factory {spec.factory!r} is not callable"


def check_plugin_module(module: ModuleType, *, import_factories: bool = True) -> list[ComponentSpec]:
    """Assert that a hooks module registers well-formed specs through known hooks; return the specs.

    Uses an isolated registry, so the check neither sees nor disturbs installed plugins.
    """
    from t2m_core.registry import Registry

    registry = Registry()
    record = registry.register_plugin(module, name=module.__name__)
    assert record.error is None, f"{module.__name__} cannot be registered: {record.error}"
    unknown = [
        name
        for name in dir(module)
        if name.startswith("t2m_")
        and inspect.isroutine(getattr(module, name))
        and name not in hookspecs.REGISTRATION_HOOKS.values()
    ]
    assert not unknown, f"{module.__name__} defines functions that are not t2m hooks: {', '.join(unknown)}"
    specs = [entry.spec for entry in registry.components()]
    failed = registry.failed_plugins()
    assert not failed, f"{module.__name__}: {failed[0].status}"
    assert specs, f"{module.__name__} registers no component"
    for spec in specs:
        check_plugin_spec(spec, import_factory=import_factories)
    return specs


def check_import_light(module_name: str, heavy: tuple[str, ...] = HEAVY_MODULES) -> None:
    """Assert that importing ``module_name`` in a fresh interpreter imports none of ``heavy``.

    The fresh interpreter gets this process's ``sys.path``, so modules importable here are there too.
    """
    probe = (
        "import importlib, json, sys; importlib.import_module(sys.argv[1]); "
        "print(json.dumps(sorted(m for m in sys.argv[2:] if m in sys.modules)))"
    )
    environment = {**os.environ, "PYTHONPATH": os.pathsep.join(path for path in sys.path if path)}
    result = subprocess.run(
        [sys.executable, "-c", probe, module_name, *heavy],
        capture_output=True,
        text=True,
        check=False,
        timeout=120,
        env=environment,
    )
    assert result.returncode == 0, f"importing {module_name} failed:\n{result.stderr}"
    imported = json.loads(result.stdout.strip().splitlines()[-1])
    assert not imported, f"importing {module_name} also imports {', '.join(imported)}: import them inside functions"
