"""Machine settings, read from the environment and never written into a run directory.

| Variable | Meaning | Default |
|---|---|---|
| ``T2M_CACHE_DIR`` | assembled model files and other caches | ``$XDG_CACHE_HOME/t2m`` or ``~/.cache/t2m`` |
| ``T2M_RUNS_DIR`` | where run directories are written | ``./runs`` |
| ``T2M_DISABLE_PLUGIN_AUTOLOAD`` | ``1``: load only builtin plugins, not third-party entry points | unset |
| ``T2M_PLUGINS`` | comma-separated extra plugin modules to load by import name | unset |

API keys stay in the providers' usual variables (``OPENAI_API_KEY``...); t2m only reads them.
"""

from __future__ import annotations

import os
from pathlib import Path


def cache_dir() -> Path:
    """Directory for caches (created on demand by the code that writes into it)."""
    if explicit := os.environ.get("T2M_CACHE_DIR"):
        return Path(explicit).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base).expanduser() / "t2m"


def runs_dir() -> Path:
    """Directory under which run directories are created."""
    return Path(os.environ.get("T2M_RUNS_DIR", "runs")).expanduser()


def plugin_autoload_disabled() -> bool:
    """True when third-party entry-point plugins must not be loaded."""
    return os.environ.get("T2M_DISABLE_PLUGIN_AUTOLOAD", "").strip().lower() in {"1", "true", "yes", "on"}


def extra_plugin_modules() -> list[str]:
    """Plugin modules named in ``T2M_PLUGINS`` (import names, comma-separated)."""
    return [name.strip() for name in os.environ.get("T2M_PLUGINS", "").split(",") if name.strip()]
