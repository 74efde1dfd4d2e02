"""The plugin registry: finds plugins, owns the naming policy, builds components.

Plugins are modules with :data:`t2m_core.hookspecs.hookimpl` functions. They are found through entry
points in group ``t2m`` (builtins and third-party plugins alike), plus the modules named in
``T2M_PLUGINS``. A plugin that fails to import is recorded as failed with its error; the others keep
working. Importing a plugin never imports its heavy dependencies: specs point at factories by import
path, and a factory is imported only by :meth:`Registry.create`.

API (small and stable; everything else is private)::

    from t2m_core.registry import get_registry

    registry = get_registry()                                  # cached, loaded from entry points
    sim = registry.create("simulator", "mujoco", {"substeps": 8})   # validated options -> component
    spec = registry.get("language_model", "gpt-4")             # alias -> spec; unknown -> PluginError
    registry.names("scene_parser")                             # ["ground-truth", ...]
    registry.validate_options("simulator", "mujoco", {})       # -> the plugin's pydantic options model
    registry.components()                                      # every (kind, spec, provider) row
    registry.plugins                                           # every loaded or failed plugin

    isolated = Registry()                                      # empty, for tests: no entry points
    isolated.register_plugin(my_hooks_module, name="mine")
    set_registry(isolated)                                     # make it the process-wide one

Kinds are the keys of :data:`t2m_core.hookspecs.REGISTRATION_HOOKS`: ``simulator``,
``skill_library``, ``feasibility_planner``, ``language_model``, ``scene_parser``, ``task_planner``.

Policy: a name or alias provided twice within a kind is a :class:`~t2m_core.errors.PluginError`
naming both providers; an unknown name is a :class:`~t2m_core.errors.PluginError` listing the valid
choices with a "did you mean". A registration hook that raises or returns something other than a list
of the kind's spec objects marks its plugin as failed (a broken install, not a wiring error).
"""

from __future__ import annotations

import difflib
import importlib
import importlib.metadata
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, replace
from types import ModuleType
from typing import Any

import pluggy
from pydantic import BaseModel, ValidationError

from t2m_core import hookspecs, settings
from t2m_core.errors import ConfigError, PluginError
from t2m_core.plugin_specs import SPEC_TYPES, ComponentSpec

BUILTIN_DISTRIBUTION = "text2motion"
"""The distribution whose entry points are builtins (loaded even with autoload disabled)."""

ENTRY_POINT_GROUP = hookspecs.PROJECT_NAME

KINDS: tuple[str, ...] = tuple(hookspecs.REGISTRATION_HOOKS)
"""Component kinds, in display order."""


@dataclass(frozen=True)
class PluginRecord:
    """One plugin the registry tried to load.

    Attributes:
        name: entry-point name (or the module name for ``T2M_PLUGINS`` and runtime registrations).
        module: import path of the hooks module (``"t2m_mujoco.hooks"``).
        provider: distribution that provides it (``"text2motion"``, a third-party package name), or
            ``"T2M_PLUGINS"`` / ``"runtime"`` when no distribution owns it.
        version: the provider's version, ``""`` when unknown.
        builtin: provided by the text2motion distribution itself.
        error: ``None`` when loaded, else a one-line ``"ExceptionType: message"``.
    """

    name: str
    module: str
    provider: str
    version: str = ""
    builtin: bool = False
    error: str | None = None

    @property
    def status(self) -> str:
        """``"ok"`` or ``"failed: <error>"``."""
        return "ok" if self.error is None else f"failed: {self.error}"


@dataclass(frozen=True)
class ComponentEntry:
    """A registered component and the plugin that provides it."""

    kind: str
    spec: ComponentSpec
    plugin: PluginRecord


def _describe(error: BaseException) -> str:
    """One line: exception type and message."""
    message = str(error).strip().splitlines()[0] if str(error).strip() else ""
    return f"{type(error).__name__}: {message}" if message else type(error).__name__


def _module_name(plugin: object) -> str:
    return (
        plugin.__name__ if isinstance(plugin, ModuleType) else f"{type(plugin).__module__}.{type(plugin).__qualname__}"
    )


class Registry:
    """A pluggy plugin manager plus the component index built from its registration hooks.

    ``Registry()`` is empty (what tests want); :meth:`from_entry_points` loads installed plugins.
    """

    def __init__(self) -> None:
        self.plugin_manager = pluggy.PluginManager(hookspecs.PROJECT_NAME)
        self.plugin_manager.add_hookspecs(hookspecs)
        self._records: dict[str, PluginRecord] = {}
        self._index: dict[str, dict[str, ComponentEntry]] | None = None  # kind -> name/alias -> entry

    # ---------------------------------------------------------------------------------------------
    # Loading
    # ---------------------------------------------------------------------------------------------

    @classmethod
    def from_entry_points(cls, *, autoload: bool | None = None, extra_modules: Iterable[str] | None = None) -> Registry:
        """A registry loaded from entry points in group ``t2m`` and from ``extra_modules``.

        Args:
            autoload: load third-party entry points too; default: not ``T2M_DISABLE_PLUGIN_AUTOLOAD``.
            extra_modules: hooks modules to import by name; default: ``T2M_PLUGINS``.
        """
        registry = cls()
        registry.load_entry_points(autoload=not settings.plugin_autoload_disabled() if autoload is None else autoload)
        for module_name in settings.extra_plugin_modules() if extra_modules is None else extra_modules:
            registry.load_module(module_name)
        return registry

    def load_entry_points(self, *, autoload: bool = True) -> None:
        """Load every entry point of group ``t2m``; only the builtins when ``autoload`` is false."""
        for entry_point in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP):
            dist = entry_point.dist
            provider = dist.name if dist is not None else "unknown"
            builtin = _normalise(provider) == _normalise(BUILTIN_DISTRIBUTION)
            if not (builtin or autoload):
                continue
            # two distributions may use the same entry-point name: keep both, told apart by provider
            name = entry_point.name if entry_point.name not in self._records else f"{provider}:{entry_point.name}"
            record = PluginRecord(
                name=name,
                module=entry_point.value,
                provider=provider,
                version=dist.version if dist is not None else "",
                builtin=builtin,
            )
            try:
                plugin = entry_point.load()
            except Exception as error:  # noqa: BLE001 - a broken install must not take the CLI down
                self._record(record, error=error)
                continue
            self._add(plugin, record)

    def load_module(self, module_name: str) -> PluginRecord:
        """Import ``module_name`` and register it (how ``T2M_PLUGINS`` entries are loaded)."""
        provider, version = _owning_distribution(module_name)
        record = PluginRecord(name=module_name, module=module_name, provider=provider, version=version)
        try:
            plugin = importlib.import_module(module_name)
        except Exception as error:  # noqa: BLE001 - recorded as a failed plugin, like a broken entry point
            return self._record(record, error=error)
        if self.plugin_manager.is_registered(plugin):  # already loaded through its entry point
            return self._records[self.plugin_manager.get_name(plugin)]
        return self._add(plugin, record)

    def register_plugin(
        self, plugin: object, *, name: str | None = None, provider: str = "runtime", version: str = ""
    ) -> PluginRecord:
        """Register an already imported hooks module or object (tests, notebooks, embedding apps).

        Raises:
            PluginError: a plugin with this name is already registered.
        """
        name = name or _module_name(plugin)
        if name in self._records:
            raise PluginError(
                f"a plugin named {name!r} is already registered (from {self._records[name].provider})",
                hint="give the new plugin another name, or unregister the old one first",
            )
        return self._add(
            plugin, PluginRecord(name=name, module=_module_name(plugin), provider=provider, version=version)
        )

    def unregister_plugin(self, name: str) -> None:
        """Remove a plugin (and its components) registered under ``name``; unknown names are ignored."""
        record = self._records.pop(name, None)
        if record is not None and self.plugin_manager.has_plugin(name):
            self.plugin_manager.unregister(name=name)
        self._index = None

    def _add(self, plugin: object, record: PluginRecord) -> PluginRecord:
        try:
            self.plugin_manager.register(plugin, name=record.name)
        except Exception as error:  # noqa: BLE001 - pluggy rejects bad hook names and signatures
            return self._record(record, error=error)
        return self._record(record)

    def _record(self, record: PluginRecord, error: BaseException | None = None) -> PluginRecord:
        if error is not None:
            record = replace(record, error=_describe(error))
        self._records[record.name] = record
        self._index = None
        return record

    # ---------------------------------------------------------------------------------------------
    # Queries
    # ---------------------------------------------------------------------------------------------

    @property
    def plugins(self) -> list[PluginRecord]:
        """Every plugin tried, loaded or failed, in load order (duplicates are reported elsewhere)."""
        try:
            self._build_index()  # a registration hook that fails turns its plugin's record into a failure
        except PluginError:
            pass  # a duplicate name: components() and get() raise it; the plugin list stays available
        return list(self._records.values())

    def failed_plugins(self) -> list[PluginRecord]:
        """Plugins that could not be loaded or whose registration hooks failed."""
        return [record for record in self.plugins if record.error is not None]

    def components(self, kind: str | None = None) -> list[ComponentEntry]:
        """Registered components (each once, aliases not repeated), in kind then name order."""
        index = self._build_index()
        kinds = KINDS if kind is None else (_check_kind(kind),)
        rows: list[ComponentEntry] = []
        for each_kind in kinds:
            unique = {entry.spec.name: entry for entry in index[each_kind].values()}
            rows.extend(unique[name] for name in sorted(unique))
        return rows

    def specs(self, kind: str) -> list[ComponentSpec]:
        """The specs registered for ``kind``, sorted by name."""
        return [entry.spec for entry in self.components(kind)]

    def names(self, kind: str) -> list[str]:
        """Canonical names registered for ``kind``, sorted."""
        return [entry.spec.name for entry in self.components(kind)]

    def entry(self, kind: str, name: str) -> ComponentEntry:
        """The component called ``name`` (or one of its aliases) and its provider.

        Raises:
            PluginError: unknown kind or name; the hint lists the valid choices and a close match.
        """
        entries = self._build_index()[_check_kind(kind)]
        if name in entries:
            return entries[name]
        choices = sorted(entries)
        close = difflib.get_close_matches(name, choices, n=1)
        suggestion = f"did you mean {close[0]!r}? " if close else ""
        valid = ", ".join(choices) if choices else "none are installed"
        failed = self.failed_plugins()
        note = f" ({len(failed)} plugin(s) failed to load: run `t2m list-plugins`)" if failed else ""
        raise PluginError(
            f"unknown {kind.replace('_', ' ')} {name!r}", hint=f"{suggestion}valid choices: {valid}{note}"
        )

    def get(self, kind: str, name: str) -> ComponentSpec:
        """The spec of ``name`` (or one of its aliases) in ``kind``; see :meth:`entry`."""
        return self.entry(kind, name).spec

    def validate_options(self, kind: str, name: str, options: BaseModel | Mapping[str, Any] | None = None) -> BaseModel:
        """``options`` validated against the component's own options model.

        Raises:
            ConfigError: one line per invalid option, ``field.path: message``.
        """
        spec = self.get(kind, name)
        if isinstance(options, spec.options):
            return options
        try:
            return spec.options.model_validate(dict(options or {}))
        except ValidationError as error:
            problems = "; ".join(
                f"{'.'.join(map(str, issue['loc'])) or '(options)'}: {issue['msg']}" for issue in error.errors()
            )
            raise ConfigError(
                f"invalid options for {kind.replace('_', ' ')} {name!r}: {problems}",
                hint=f"valid options: {', '.join(spec.options.model_fields) or 'none'}",
            ) from None

    def create(self, kind: str, name: str, options: BaseModel | Mapping[str, Any] | None = None) -> Any:
        """Build the component ``name`` of ``kind`` from validated ``options``.

        Raises:
            PluginError: unknown name, or its factory cannot be imported (a missing dependency).
            ConfigError: invalid options.
        """
        entry = self.entry(kind, name)
        validated = self.validate_options(kind, name, options)
        try:
            factory = entry.spec.load_factory()
        except (ImportError, AttributeError, ValueError) as error:
            raise PluginError(
                f"cannot load the factory of {kind.replace('_', ' ')} {entry.spec.name!r} "
                f"({entry.spec.factory}): {_describe(error)}",
                hint=f"reinstall {entry.plugin.provider} with its dependencies",
            ) from error
        return factory(validated)

    # ---------------------------------------------------------------------------------------------
    # Index
    # ---------------------------------------------------------------------------------------------

    def _build_index(self) -> dict[str, dict[str, ComponentEntry]]:
        if self._index is not None:
            return self._index
        index: dict[str, dict[str, ComponentEntry]] = {kind: {} for kind in KINDS}
        for kind, hook_name in hookspecs.REGISTRATION_HOOKS.items():
            for implementation in getattr(self.plugin_manager.hook, hook_name).get_hookimpls():
                record = self._records.get(implementation.plugin_name)
                if record is None or record.error is not None:
                    continue
                try:
                    specs = _checked_specs(kind, hook_name, implementation.function())
                except Exception as error:  # noqa: BLE001 - a buggy plugin is listed as failed, the rest keep working
                    self._records[record.name] = replace(record, error=_describe(error))
                    continue
                for spec in specs:
                    _insert(index[kind], ComponentEntry(kind=kind, spec=spec, plugin=record))
        # a plugin marked failed above may have registered specs before failing: drop them
        failed = {name for name, record in self._records.items() if record.error is not None}
        for entries in index.values():
            for key in [key for key, entry in entries.items() if entry.plugin.name in failed]:
                del entries[key]
        self._index = index
        return index


def _insert(entries: dict[str, ComponentEntry], new: ComponentEntry) -> None:
    """Add ``new`` under its name and aliases; a clash is a wiring error naming both providers."""
    for key in (new.spec.name, *new.spec.aliases):
        if key in entries:
            old = entries[key]
            raise PluginError(
                f"{new.kind.replace('_', ' ')} name {key!r} is provided twice: by "
                f"{_provider_label(old.plugin)} and by {_provider_label(new.plugin)}",
                hint="uninstall one of the two packages, or set T2M_DISABLE_PLUGIN_AUTOLOAD=1 to load builtins only",
            )
        entries[key] = new


def _provider_label(record: PluginRecord) -> str:
    version = f" {record.version}" if record.version else ""
    return f"{record.provider}{version} (plugin {record.name!r}, {record.module})"


def _checked_specs(kind: str, hook_name: str, result: object) -> list[ComponentSpec]:
    spec_type = SPEC_TYPES[kind]
    if result is None:
        return []
    if not isinstance(result, (list, tuple)) or not all(isinstance(spec, spec_type) for spec in result):
        raise TypeError(f"{hook_name} must return a list of {spec_type.__name__}, got {result!r:.200}")
    for spec in result:
        if not isinstance(spec.options, type) or not issubclass(spec.options, BaseModel):
            raise TypeError(f"{spec_type.__name__} {spec.name!r}: options must be a pydantic model class")
    return list(result)


def _check_kind(kind: str) -> str:
    if kind not in KINDS:
        close = difflib.get_close_matches(kind, KINDS, n=1)
        suggestion = f"did you mean {close[0]!r}? " if close else ""
        raise PluginError(f"unknown component kind {kind!r}", hint=f"{suggestion}valid kinds: {', '.join(KINDS)}")
    return kind


def _normalise(distribution_name: str) -> str:
    return distribution_name.lower().replace("_", "-").replace(".", "-")


def _owning_distribution(module_name: str) -> tuple[str, str]:
    """(distribution, version) that installs the top-level package of ``module_name``, if any."""
    top_level = module_name.partition(".")[0]
    owners = importlib.metadata.packages_distributions().get(top_level, [])
    if not owners:
        return "T2M_PLUGINS", ""
    try:
        return owners[0], importlib.metadata.version(owners[0])
    except importlib.metadata.PackageNotFoundError:
        return owners[0], ""


_default_registry: Registry | None = None


def get_registry() -> Registry:
    """The process-wide registry, loaded from entry points and ``T2M_PLUGINS`` on first use."""
    global _default_registry
    if _default_registry is None:
        _default_registry = Registry.from_entry_points()
    return _default_registry


def set_registry(registry: Registry | None) -> Registry | None:
    """Make ``registry`` the process-wide one (``None``: reload on next use); return the previous one.

    Tests use it to run CLI commands against an isolated registry.
    """
    global _default_registry
    previous, _default_registry = _default_registry, registry
    return previous


def reset_registry() -> None:
    """Forget the process-wide registry: the next :func:`get_registry` reloads it from entry points."""
    set_registry(None)
