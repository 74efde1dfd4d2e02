"""Docs pages, CLI help texts, docstrings and error hints name only config keys, commands and
options that exist.

What is checked, wherever it appears:

- ``--set KEY=VALUE``: a dotted key must be a path of the run configuration's pydantic schema
  (``simulator.options.X`` an option of some registered simulator, or of an in-repo example
  plugin); a single key a top-level config key or an option of some component (``t2m llm --set``
  takes single language-model options);
- ```t2m COMMAND [SUBCOMMAND] --option``` in code spans and code blocks: the command exists in the
  typer app and takes every ``--option`` named after it.
"""

from __future__ import annotations

import ast
import importlib
import re
import sys
import typing
from collections.abc import Iterator
from functools import cache
from pathlib import Path
from types import UnionType

import pytest
import typer.main
from pydantic import BaseModel

from t2m_core.cli.main import app
from t2m_core.config.models import COMPONENT_BLOCKS, ComponentConfig, RunConfig
from t2m_core.registry import get_registry

ROOT = Path(__file__).parents[1]
SET_KEY = re.compile(r"--set[ =]+([A-Za-z_]\w*(?:\.[A-Za-z_]\w*)*)(?:=|\.\.\.)")
PLACEHOLDER_KEYS = {"a.b", "a.b.c", "dotted.key", "key"}
CODE_SPAN = re.compile(r"``?([^`\n]+?)``?")
COMMAND = re.compile(r"(?<![\w/.-])t2m((?:\s+[a-z][\w-]*)+)([^|;#&]*)")


# --------------------------------------------------------------------------------------------------
# What exists
# --------------------------------------------------------------------------------------------------


@cache
def commands() -> dict[tuple[str, ...], frozenset[str]]:
    """Command path (``("tasks", "show")``; groups included) -> the options it takes."""
    found: dict[tuple[str, ...], frozenset[str]] = {}

    def walk(command, path: tuple[str, ...], inherited: frozenset[str]) -> None:
        options = inherited | {o for p in command.params for o in (*p.opts, *getattr(p, "secondary_opts", ())) if o.startswith("-")}
        found[path] = frozenset(options | {"--help"})
        for name, sub in getattr(command, "commands", {}).items():
            walk(sub, (*path, name), frozenset())

    walk(typer.main.get_command(app), (), frozenset())
    return found


def _example_option_models(kind: str) -> list[type[BaseModel]]:
    """Options models of the in-repo example plugins (not installed in the test environment)."""
    models = []
    for hooks in sorted(ROOT.glob("examples/*/*/hooks.py")):
        sys.path.insert(0, str(hooks.parents[1]))
        try:
            module = importlib.import_module(f"{hooks.parent.name}.hooks")
        finally:
            sys.path.pop(0)
        for name in dir(module):
            if name.startswith("t2m_register_"):
                models += [spec.options for spec in getattr(module, name)() if spec.kind == kind]
    return models


@cache
def option_names(kind: str | None = None) -> frozenset[str]:
    """Options of every registered component of ``kind`` (every kind when ``None``), examples included."""
    registry = get_registry()
    kinds = [kind] if kind else sorted(set(COMPONENT_BLOCKS.values()))
    names: set[str] = set()
    for each in kinds:
        for model in [spec.options for spec in registry.specs(each)] + _example_option_models(each):
            names |= set(model.model_fields)
    return frozenset(names)


def _model_of(annotation) -> type[BaseModel] | None:
    """The pydantic model inside ``annotation`` (``Model | None`` included)."""
    candidates = typing.get_args(annotation) if isinstance(annotation, UnionType) or typing.get_origin(annotation) else (annotation,)
    return next((c for c in candidates if isinstance(c, type) and issubclass(c, BaseModel)), None)


def config_key_problem(key: str) -> str | None:
    """Why ``--set key=...`` names nothing that exists, or ``None``."""
    if key in PLACEHOLDER_KEYS or any(part.isupper() for part in key.split(".")):
        return None
    parts = key.split(".")
    if len(parts) == 1:
        ok = key in RunConfig.model_fields or key in option_names()
        return None if ok else f"{key!r} is neither a run-config key nor an option of any component"
    model: type[BaseModel] | None = RunConfig
    for depth, part in enumerate(parts):
        if model is None:
            return f"{'.'.join(parts[:depth])} has no keys below it"
        if model is ComponentConfig and parts[depth - 1] in COMPONENT_BLOCKS and part == "options" and depth + 1 < len(parts):
            option = parts[depth + 1]
            kind = COMPONENT_BLOCKS[parts[depth - 1]]
            return None if option in option_names(kind) else f"no registered {kind} has an option {option!r}"
        if part not in model.model_fields:
            return f"{'.'.join(parts[: depth + 1])} is not a config key (keys here: {', '.join(model.model_fields)})"
        model = _model_of(model.model_fields[part].annotation)
    return None


def command_problems(text: str) -> Iterator[str]:
    """Problems with the ``t2m ...`` command lines in ``text`` (a code span or code-block line)."""
    for match in COMMAND.finditer(text):
        words, rest = match.group(1).split(), match.group(2)
        path: tuple[str, ...] = ()
        for word in words:
            if (*path, word) in commands():
                path = (*path, word)
            else:
                break
        if not path:
            yield f"`t2m {words[0]}`: no such command (commands: {', '.join(sorted(p[0] for p in commands() if len(p) == 1))})"
            continue
        for option in re.findall(r"(?<![\w-])(--[a-z][\w-]*)", match.group(1) + rest):
            if option not in commands()[path]:
                yield f"`t2m {' '.join(path)}` has no option {option}"


# --------------------------------------------------------------------------------------------------
# Where names appear
# --------------------------------------------------------------------------------------------------


def markdown_pages() -> list[Path]:
    pages = [*ROOT.glob("docs/**/*.md"), ROOT / "README.md", *ROOT.glob("examples/*/README.md")]
    return sorted(page for page in pages if page.is_file())


def python_strings() -> Iterator[tuple[str, str]]:
    """``(where, text)`` of every string constant in the sources: messages, hints, help, docstrings."""
    roots = [ROOT / "t2m_core", ROOT / "plugins", ROOT / "examples", ROOT / "benchmarks"]
    for path in sorted(p for root in roots for p in root.rglob("*.py")):
        try:
            tree = ast.parse(path.read_text(encoding="utf-8"))
        except SyntaxError:
            continue
        for node in ast.walk(tree):
            if isinstance(node, ast.Constant) and isinstance(node.value, str):
                yield f"{path.relative_to(ROOT)}:{node.lineno}", node.value


def help_texts() -> Iterator[tuple[str, str]]:
    def walk(command, path: str) -> Iterator[tuple[str, str]]:
        yield f"t2m {path}".strip(), command.help or ""
        for param in command.params:
            yield f"t2m {path} {param.opts}".strip(), getattr(param, "help", None) or ""
        for name, sub in getattr(command, "commands", {}).items():
            yield from walk(sub, f"{path} {name}".strip())

    yield from walk(typer.main.get_command(app), "")


def code_texts(text: str) -> Iterator[str]:
    """Code spans, and the lines of fenced code blocks, of a Markdown page or a docstring."""
    fenced = False
    for line in text.splitlines():
        if line.lstrip().startswith("```"):
            fenced = not fenced
        elif fenced:
            yield line.split(" #")[0]  # a shell comment is prose
        else:
            yield from CODE_SPAN.findall(line)


def all_texts() -> Iterator[tuple[str, str]]:
    """``(where, text)``: ``--set`` keys are looked for in the whole text, command lines in its code
    spans and code blocks."""
    for page in markdown_pages():
        yield str(page.relative_to(ROOT)), page.read_text(encoding="utf-8")
    yield from python_strings()
    yield from help_texts()


# --------------------------------------------------------------------------------------------------
# Tests
# --------------------------------------------------------------------------------------------------


def test_every_set_key_exists() -> None:
    problems = [
        f"{where}: --set {key}: {why}"
        for where, text in all_texts()
        for key in SET_KEY.findall(text)
        if (why := config_key_problem(key))
    ]
    assert not problems, "texts name config keys that do not exist:\n" + "\n".join(sorted(set(problems)))


def test_every_named_command_and_option_exists() -> None:
    problems = [
        f"{where}: {problem}"
        for where, text in all_texts()
        for snippet in code_texts(text)
        for problem in command_problems(snippet)
    ]
    assert not problems, "texts name commands or options that do not exist:\n" + "\n".join(sorted(set(problems)))


@pytest.mark.parametrize(
    ("key", "ok"),
    [
        ("seed", True),
        ("simulator.options.substeps", True),
        ("language_model.options.model_path", True),
        ("output.video", True),
        ("n_ctx", True),
        ("llm.options.model_path", False),
        ("simulator.options.no_such_option", False),
        ("output.video.fps", False),
        ("sim.options.substeps", False),
    ],
)
def test_config_keys_are_checked_against_the_schema(key: str, ok: bool) -> None:
    assert (config_key_problem(key) is None) == ok, config_key_problem(key)


def test_set_keys_are_found_with_a_value_or_an_ellipsis() -> None:
    assert SET_KEY.findall("--set seed=3, --set simulator.options..., --set language_model.options.n_ctx=4") == [
        "seed", "simulator.options", "language_model.options.n_ctx"
    ]


def test_commands_and_options_are_checked_against_the_app() -> None:
    assert list(command_problems("t2m tasks show task1 --seed 3 --json")) == []
    assert list(command_problems("t2m sim demo --task task0 --out DIR")) == []
    assert list(command_problems("t2m run --task task0")) == []
    assert list(command_problems("t2m runn --task task0")) != []
    assert list(command_problems("t2m sim demo --tsak task0")) != []
