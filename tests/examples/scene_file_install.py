"""Installs the example plugin for a test the way `pip install -e examples/t2m-scene-file` would."""

from __future__ import annotations

import tomllib
from pathlib import Path

EXAMPLE = Path(__file__).parents[2] / "examples" / "t2m-scene-file"


def install_example(t2m_fake_distribution, monkeypatch) -> None:
    """Metadata with the example's own entry points (from its pyproject), and its source on sys.path."""
    project = tomllib.loads((EXAMPLE / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    monkeypatch.syspath_prepend(str(EXAMPLE))
    t2m_fake_distribution(project["name"], version=project["version"], entry_points=project["entry-points"]["t2m"])
