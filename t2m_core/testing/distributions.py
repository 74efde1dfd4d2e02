"""Fake installed distributions: what entry-point discovery sees when a package is pip-installed.

A fake distribution is a ``<name>-<version>.dist-info`` folder (``METADATA``, ``entry_points.txt``)
plus its modules, written into a folder that is then put on ``sys.path``; ``importlib.metadata``
finds it exactly as it finds a real installed package.
"""

from __future__ import annotations

import textwrap
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class FakeDistribution:
    """A distribution written by :func:`write_fake_distribution`.

    Attributes:
        name: distribution name (``"acme-t2m"``).
        version: its version.
        site: the folder to put on ``sys.path``.
        modules: top-level module or package names it provides.
    """

    name: str
    version: str
    site: Path
    modules: tuple[str, ...]


def write_fake_distribution(
    site: Path,
    name: str,
    *,
    version: str = "1.0.0",
    entry_points: Mapping[str, str] | None = None,
    files: Mapping[str, str] | None = None,
    group: str = "t2m",
) -> FakeDistribution:
    """Write a distribution called ``name`` into ``site``.

    Args:
        site: folder that will go on ``sys.path`` (created if needed).
        name: distribution name.
        version: distribution version.
        entry_points: entry-point name -> ``"module"`` or ``"module:attr"``, in ``group``.
        files: relative path -> source text of the modules it ships (dedented).
        group: entry-point group.
    """
    site.mkdir(parents=True, exist_ok=True)
    for relative, source in (files or {}).items():
        path = site / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(textwrap.dedent(source), encoding="utf-8")
    dist_info = site / f"{name.replace('-', '_')}-{version}.dist-info"
    dist_info.mkdir(exist_ok=True)
    (dist_info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: {version}\n", encoding="utf-8")
    lines = [f"[{group}]", *(f"{key} = {value}" for key, value in (entry_points or {}).items())]
    (dist_info / "entry_points.txt").write_text("\n".join(lines) + "\n", encoding="utf-8")
    modules = sorted({Path(relative).parts[0].removesuffix(".py") for relative in (files or {})})
    (dist_info / "top_level.txt").write_text("\n".join(modules) + "\n", encoding="utf-8")
    return FakeDistribution(name=name, version=version, site=site, modules=tuple(modules))
