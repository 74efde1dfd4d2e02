"""The docs stay honest: every hook is documented and tested, and the site builds with --strict."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from t2m_core import hookspecs

ROOT = Path(__file__).parents[1]
HOOKS = sorted(name for name in dir(hookspecs) if name.startswith("t2m_"))


def test_the_registration_hooks_are_all_the_hooks() -> None:
    assert HOOKS == sorted(hookspecs.REGISTRATION_HOOKS.values())


@pytest.mark.parametrize("hook", HOOKS)
def test_hook_is_documented_in_the_plugin_guide(hook: str) -> None:
    assert f"`{hook}`" in (ROOT / "docs" / "guide" / "plugins.md").read_text(encoding="utf-8")


@pytest.mark.parametrize("hook", HOOKS)
def test_hook_is_exercised_by_a_test(hook: str) -> None:
    sources = [
        path.read_text(encoding="utf-8") for path in (ROOT / "tests").rglob("*.py") if path.name != "test_docs.py"
    ]
    assert any(f"def {hook}(" in source or f"{hook}=" in source for source in sources), (
        f"no test plugin implements {hook}"
    )


@pytest.mark.parametrize("hook", HOOKS)
def test_hook_docstring_has_a_complete_example(hook: str) -> None:
    doc = getattr(hookspecs, hook).__doc__ or ""
    assert "Example::" in doc and "@hookimpl" in doc and f"def {hook}():" in doc


def test_every_nav_page_exists() -> None:
    def pages(node: object) -> list[str]:
        if isinstance(node, str):
            return [node]
        if isinstance(node, dict):
            return [page for value in node.values() for page in pages(value)]
        if isinstance(node, list):
            return [page for item in node for page in pages(item)]
        return []

    nav = yaml.safe_load((ROOT / "mkdocs.yml").read_text(encoding="utf-8"))["nav"]
    missing = [page for page in pages(nav) if not (ROOT / "docs" / page).is_file()]
    assert not missing, f"pages in mkdocs.yml nav but not in docs/: {missing}"


def test_site_builds_strictly_with_the_generated_reference(tmp_path: Path) -> None:
    site = tmp_path / "site"
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "mkdocs",
            "build",
            "--strict",
            "--config-file",
            str(ROOT / "mkdocs.yml"),
            "--site-dir",
            str(site),
        ],
        capture_output=True,
        text=True,
        check=False,
        cwd=ROOT,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
        timeout=300,
    )
    assert result.returncode == 0, result.stderr[-4000:]
    cli = (site / "reference" / "cli" / "index.html").read_text(encoding="utf-8")
    assert "t2m config show" in cli and "t2m list-plugins" in cli and "--set" in cli
    hooks_page = (site / "reference" / "hooks" / "index.html").read_text(encoding="utf-8")
    assert all(hook in hooks_page for hook in HOOKS)
    config_page = (site / "reference" / "configuration" / "index.html").read_text(encoding="utf-8")
    assert "simulator.options" in config_page and "output.video_fps" in config_page
    assert "ground-truth" in (site / "reference" / "plugins" / "index.html").read_text(encoding="utf-8")
