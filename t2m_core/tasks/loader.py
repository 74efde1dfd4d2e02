"""Loading and validating task files (YAML) into :class:`Task` values.

The seven tasks of the suite ship as package data (``t2m_core/tasks/data/task0.yaml`` …). A task
file is validated strictly: unknown keys, unknown objects or predicates, malformed propositions,
goals outside the scene's proposition set and ill-typed skeleton skills are errors that name the
file and the key.
"""

from __future__ import annotations

import difflib
from importlib import resources
from pathlib import Path
from typing import Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from t2m_core.domain.goals import Goal, GoalError, validate_goal
from t2m_core.domain.literals import LiteralSyntaxError
from t2m_core.domain.objects import OBJECTS
from t2m_core.domain.propositions import (
    PREDICATE_ORDER,
    Proposition,
    PropositionError,
    canonical_order,
    validate_proposition,
)
from t2m_core.domain.skills import SkillError, parse_skill_call, validate_skill_call
from t2m_core.errors import T2MError
from t2m_core.tasks.model import Task

_DATA_PACKAGE = "t2m_core.tasks.data"


class TaskFileError(T2MError):
    """A task file that cannot be read or does not describe a valid task."""


class TaskNotFoundError(T2MError, KeyError):
    """An unknown task id."""

    def __str__(self) -> str:  # KeyError would quote the message
        return T2MError.__str__(self)


class TaskFile(BaseModel):
    """The schema of a task file; every key is required except ``paper_task``."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    id: str = Field(pattern=r"^[A-Za-z0-9_.-]+$")
    name: str
    properties: list[Literal["LH", "LG", "PAP"]]
    paper_task: int | None = None
    instruction: str = Field(min_length=1)
    objects: list[str] = Field(min_length=2, max_length=7)
    rack_zone: Literal["inworkspace", "beyondworkspace"]
    initial_state: list[str]
    goal: list[list[str]] = Field(min_length=1)
    reference_skeleton: list[str]


def load_task_file(path: str | Path) -> Task:
    """Load and validate one task file.

    Raises:
        TaskFileError: naming the file, the key and the problem.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as error:
        raise TaskFileError(f"cannot read task file {path}: {error.strerror or error}") from None
    return parse_task(text, source=path)


def parse_task(text: str, source: Path | str = "<task>") -> Task:
    """Parse and validate a task from YAML text; ``source`` names it in error messages.

    Raises:
        TaskFileError: naming the source, the key and the problem.
    """
    where = str(source)
    try:
        raw = yaml.safe_load(text)
    except yaml.YAMLError as error:
        raise TaskFileError(f"{where}: invalid YAML: {error}") from None
    if not isinstance(raw, dict):
        keys = ", ".join(TaskFile.model_fields)
        raise TaskFileError(f"{where}: a task file must be a mapping of keys", f"keys: {keys}")
    try:
        data = TaskFile.model_validate(raw)
    except ValidationError as error:
        first = error.errors()[0]
        key = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in first["loc"]).lstrip(".") or "<root>"
        hint = f"allowed keys: {', '.join(TaskFile.model_fields)}" if first["type"] == "extra_forbidden" else None
        problem = "unknown key" if first["type"] == "extra_forbidden" else first["msg"]
        raise TaskFileError(f"{where}: key {key!r}: {problem}", hint) from None
    return _build_task(data, where, Path(source) if isinstance(source, Path) else None)


def _build_task(data: TaskFile, where: str, source: Path | None) -> Task:
    def fail(key: str, message: str, hint: str | None = None) -> TaskFileError:
        return TaskFileError(f"{where}: key {key!r}: {message}", hint)

    for i, name in enumerate(data.objects):
        if name not in OBJECTS:
            raise fail(f"objects[{i}]", f"unknown object {name!r}", f"known objects: {', '.join(OBJECTS)}")
    if len(set(data.objects)) != len(data.objects):
        raise fail("objects", "an object is listed twice")
    for required in ("table", "rack"):
        if required not in data.objects:
            raise fail("objects", f"every task needs the {required}")
    instruction = data.instruction.strip()  # the original stored two instructions with a trailing space

    initial: list[Proposition] = []
    for i, entry in enumerate(data.initial_state):
        try:
            proposition = Proposition.parse(entry)
            validate_proposition(proposition, data.objects, PREDICATE_ORDER)
        except (LiteralSyntaxError, PropositionError) as error:
            raise fail(f"initial_state[{i}]", error.message, error.hint) from None
        initial.append(proposition)
    if Proposition(data.rack_zone, ("rack",)) not in initial:
        raise fail("rack_zone", f"{data.rack_zone}(rack) is not in the initial state", "add it, or fix rack_zone")

    alternatives = []
    for i, alternative in enumerate(data.goal):
        props = []
        for j, entry in enumerate(alternative):
            try:
                props.append(Proposition.parse(entry))
            except LiteralSyntaxError as error:
                raise fail(f"goal[{i}][{j}]", error.message, "quote each proposition: \"on(a, b)\"") from None
        alternatives.append(tuple(props))
    try:
        goal = Goal(tuple(alternatives))
        validate_goal(goal, data.objects)
    except GoalError as error:
        raise fail("goal", error.message, error.hint) from None

    skeleton = []
    for i, entry in enumerate(data.reference_skeleton):
        try:
            call = parse_skill_call(entry, data.objects)
            validate_skill_call(call, data.objects)
        except SkillError as error:
            raise fail(f"reference_skeleton[{i}]", error.message, error.hint) from None
        skeleton.append(call)

    return Task(
        id=data.id,
        name=data.name,
        properties=tuple(dict.fromkeys(data.properties)),
        paper_task=data.paper_task,
        instruction=instruction,
        objects=tuple(data.objects),
        rack_zone=data.rack_zone,
        initial_state=canonical_order(initial),
        goal=goal,
        reference_skeleton=tuple(skeleton),
        source=source,
    )


# --------------------------------------------------------------------------------------------------
# The shipped suite
# --------------------------------------------------------------------------------------------------


def _data_files() -> list[Path]:
    root = resources.files(_DATA_PACKAGE)
    return sorted((Path(str(f)) for f in root.iterdir() if f.name.endswith(".yaml")), key=lambda p: p.name)


def list_tasks() -> tuple[Task, ...]:
    """Every shipped task, ordered by id (task0 … task6)."""
    return tuple(load_task_file(path) for path in _data_files())


def task_ids() -> tuple[str, ...]:
    """The shipped task ids, without loading the files."""
    return tuple(path.stem for path in _data_files())


def load_task(task_id: str) -> Task:
    """A shipped task by id (``"task3"``), by its bare number (``"3"``) or by internal name
    (``"lh_lg_po_2"``), or any task file by path (``"my_tasks/kitchen.yaml"``).

    Raises:
        TaskNotFoundError: with a "did you mean" and the valid ids.
        TaskFileError: the file exists but is invalid.
    """
    key = str(task_id).strip()
    if key.endswith((".yaml", ".yml")) or "/" in key:
        return load_task_file(key)
    ids = task_ids()
    if key.isdigit() and f"task{key}" in ids:
        key = f"task{key}"
    if key in ids:
        return load_task_file(next(p for p in _data_files() if p.stem == key))
    by_name = {task.name: task for task in list_tasks()}
    if key in by_name:
        return by_name[key]
    close = difflib.get_close_matches(key, [*ids, *by_name], n=1)
    suggestion = f"did you mean {close[0]!r}? " if close else ""
    raise TaskNotFoundError(f"unknown task {key!r}", f"{suggestion}valid tasks: {', '.join(ids)}")

