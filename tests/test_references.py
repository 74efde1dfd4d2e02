"""Every reference in the code, tests, docs and benchmarks points inside this repository.

The method is described in docs/guide/*.md; code and docs point at it as
``docs/guide/<page>.md#<anchor>`` (in Markdown pages also as relative links ``[text](<page>.md#<anchor>)``).
These tests fail on references to specification documents that are not in the repository and on
pointers whose page or heading does not exist.
"""

from __future__ import annotations

import re
import subprocess
import unicodedata
from functools import cache
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[1]
GUIDE = ROOT / "docs" / "guide"

OUTSIDE_REFERENCES = {
    "a specification document": re.compile(r"\b(?:tableenv|text2motion)\.md\b|\btasks\.md\s*§"),
    "a numbered quirk": re.compile(r"\bquirk\s+Q\d|\bQ\d{1,2}\b(?!_)"),
    "a section number": re.compile(r"§\s*\d"),
}
"""What a reference outside the repository looks like, by kind."""

GUIDE_POINTER = re.compile(r"docs/guide/([\w-]+)\.md(?:#([\w-]+))?")
"""``docs/guide/<page>.md#<anchor>`` anywhere in a file."""
RELATIVE_LINK = re.compile(r"\]\((?!https?:)([\w./-]*?\.md)?(?:#([\w-]+))?\)")
"""``[text](page.md#anchor)``, ``[text](#anchor)`` or ``[text](page.md)`` in a Markdown page."""


def tracked_files(*suffixes: str) -> list[Path]:
    """Files git tracks or would track (untracked but not ignored), with one of ``suffixes``."""
    listed = subprocess.run(
        ["git", "ls-files", "--cached", "--others", "--exclude-standard"],
        cwd=ROOT, capture_output=True, text=True, check=True,
    ).stdout.splitlines()
    return sorted({ROOT / name for name in listed if name.endswith(suffixes) and (ROOT / name).is_file()})


def slugify(heading: str) -> str:
    """The anchor mkdocs (Python-Markdown's toc) gives a heading: lower case, punctuation dropped,
    spaces to hyphens."""
    text = re.sub(r"`([^`]*)`", r"\1", heading)
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", text)  # a link in a heading keeps its text
    text = unicodedata.normalize("NFKD", text).encode("ascii", "ignore").decode("ascii")
    text = re.sub(r"[^\w\s-]", "", text).strip().lower()
    return re.sub(r"[-\s]+", "-", text)


@cache
def anchors(page: Path) -> frozenset[str]:
    """The heading anchors of a Markdown page (headings inside code fences are not headings)."""
    found, fenced = set(), False
    for line in page.read_text(encoding="utf-8").splitlines():
        if line.lstrip().startswith("```"):
            fenced = not fenced
        elif not fenced and (match := re.match(r"#{1,6}\s+(.+?)\s*#*\s*$", line)):
            found.add(slugify(match.group(1)))
    return frozenset(found)


def dangling(page: Path, anchor: str | None) -> str | None:
    """Why a pointer to ``page#anchor`` does not resolve, or ``None``."""
    shown = page.relative_to(ROOT) if page.is_relative_to(ROOT) else page
    if not page.is_file():
        return f"no page {shown}"
    if anchor and anchor not in anchors(page):
        return f"no heading with anchor #{anchor} in {shown}"
    return None


def test_slugify_matches_mkdocs() -> None:
    assert slugify("Executing a primitive (the backend contract)") == "executing-a-primitive-the-backend-contract"
    assert slugify("`t2m sim demo`") == "t2m-sim-demo"
    assert slugify("task3's reference skeleton") == "task3s-reference-skeleton"
    assert slugify("Q-ensemble") == "q-ensemble"


@pytest.mark.parametrize("kind", sorted(OUTSIDE_REFERENCES))
def test_no_reference_points_outside_the_repository(kind: str) -> None:
    pattern = OUTSIDE_REFERENCES[kind]
    this_file = Path(__file__).resolve()
    found = [
        f"{path.relative_to(ROOT)}:{number}: {line.strip()[:120]}"
        for path in tracked_files(".py", ".md", ".yaml", ".yml")
        if path.resolve() != this_file
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1)
        if pattern.search(line)
    ]
    assert not found, (
        f"{len(found)} lines point at {kind} outside the repository; point at a docs page instead "
        "(docs/guide/<page>.md#<anchor>) or drop the reference:\n" + "\n".join(found)
    )


def test_every_guide_pointer_resolves() -> None:
    this_file = Path(__file__).resolve()
    problems = [
        f"{path.relative_to(ROOT)}: docs/guide/{page}.md{'#' + anchor if anchor else ''}: {why}"
        for path in tracked_files(".py", ".md", ".yaml", ".yml", ".toml")
        if path.resolve() != this_file
        for page, anchor in GUIDE_POINTER.findall(path.read_text(encoding="utf-8"))
        if (why := dangling(GUIDE / f"{page}.md", anchor or None))
    ]
    assert not problems, "pointers to missing pages or headings:\n" + "\n".join(problems)


def test_every_relative_link_in_the_docs_resolves() -> None:
    problems = []
    for path in sorted((ROOT / "docs").rglob("*.md")):
        for target, anchor in RELATIVE_LINK.findall(path.read_text(encoding="utf-8")):
            page = (path.parent / target).resolve() if target else path
            if page.is_relative_to(ROOT / "docs" / "reference") and not page.is_file():
                continue  # generated at build time by docs/hooks/reference.py
            if why := dangling(page, anchor or None):
                problems.append(f"{path.relative_to(ROOT)}: ({target}#{anchor}): {why}")
    assert not problems, "links to missing pages or headings:\n" + "\n".join(problems)


def test_a_dangling_pointer_is_reported(tmp_path: Path) -> None:
    page = tmp_path / "page.md"
    page.write_text("# Title\n\n## Some heading\n\n```\n## not a heading\n```\n", encoding="utf-8")
    assert dangling(page, "some-heading") is None and dangling(page, "title") is None
    assert dangling(page, "not-a-heading") is not None
