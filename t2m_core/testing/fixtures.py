"""pytest fixtures for plugin authors (loaded in every pytest session through the ``pytest11`` entry point).

- ``t2m_registry``: an empty, isolated :class:`~t2m_core.registry.Registry`, installed as the
  process-wide registry for the test, so CLI commands see only what the test registers.
- ``t2m_plugin``: ``t2m_plugin(hooks_module_or_object, name=...)`` registers a throwaway plugin into
  the process-wide registry; it is unregistered at teardown, whatever the test did.
- ``t2m_fake_distribution``: ``t2m_fake_distribution("acme-t2m", entry_points={...}, files={...})``
  writes an installed-looking distribution into a temporary folder on ``sys.path`` and makes the
  next :func:`~t2m_core.registry.get_registry` discover it through its entry points; all of it is
  removed at teardown. It reloads the process-wide registry, so it replaces a ``t2m_registry``
  requested by the same test: use one or the other.

This module is imported by every pytest run in an environment where t2m is installed: keep it light.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pytest

if TYPE_CHECKING:
    from t2m_core.registry import PluginRecord, Registry
    from t2m_core.testing.distributions import FakeDistribution


@pytest.fixture
def t2m_registry() -> Iterator[Registry]:
    """An empty registry (no entry points loaded), used as the process-wide one during the test."""
    from t2m_core.registry import Registry, set_registry

    registry = Registry()
    previous = set_registry(registry)
    try:
        yield registry
    finally:
        set_registry(previous)


@pytest.fixture
def t2m_plugin() -> Iterator[Callable[..., PluginRecord]]:
    """Register throwaway plugins into the process-wide registry; each is unregistered at teardown."""
    from t2m_core.registry import get_registry

    registered: list[tuple[Registry, str]] = []

    def register(
        plugin: object, *, name: str | None = None, provider: str = "tests", version: str = ""
    ) -> PluginRecord:
        registry = get_registry()
        record = registry.register_plugin(plugin, name=name, provider=provider, version=version)
        registered.append((registry, record.name))
        return record

    try:
        yield register
    finally:
        for registry, name in reversed(registered):
            registry.unregister_plugin(name)


@pytest.fixture
def t2m_fake_distribution(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Callable[..., FakeDistribution]]:
    """Write fake installed distributions that entry-point discovery finds; removed at teardown."""
    from t2m_core.registry import reset_registry
    from t2m_core.testing.distributions import write_fake_distribution

    site = tmp_path / "site-packages"
    written: list[FakeDistribution] = []

    def make(
        name: str,
        *,
        version: str = "1.0.0",
        entry_points: Mapping[str, str] | None = None,
        files: Mapping[str, str] | None = None,
    ) -> FakeDistribution:
        distribution = write_fake_distribution(site, name, version=version, entry_points=entry_points, files=files)
        if str(site) not in sys.path:
            monkeypatch.syspath_prepend(str(site))
        importlib.invalidate_caches()
        reset_registry()  # the next get_registry() sees the new distribution
        written.append(distribution)
        return distribution

    try:
        yield make
    finally:
        _forget_modules({module for distribution in written for module in distribution.modules})
        reset_registry()
        importlib.invalidate_caches()


def _forget_modules(top_level: set[str]) -> None:
    """Drop the fake packages' modules from ``sys.modules`` so no later test imports them by accident."""
    for name in [name for name in sys.modules if name.partition(".")[0] in top_level]:
        del sys.modules[name]


def pytest_report_header(config: Any) -> str | None:
    """Show the t2m version in pytest's header (a cheap sign that the fixtures are active)."""
    from t2m_core import __version__

    return f"t2m: {__version__} (fixtures t2m_registry, t2m_plugin, t2m_fake_distribution)"
