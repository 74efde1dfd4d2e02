"""The four skills as the language layer names them: signatures, calls, parsing, and the syntax and
argument-type checks of a call (docs/guide/world.md#skills-symbolic-side). What a call requires of
and does to a symbolic state is :mod:`t2m_core.domain.symbolic_effects`; the enumerations of
skill-data generation are :mod:`t2m_core.domain.enumeration`.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from t2m_core.domain.literals import (
    LiteralSyntaxError,
    extract_first_list,
    format_string_list,
    parse_call,
    parse_string_lists,
)
from t2m_core.domain.objects import OBJECTS, ObjectKind, object_spec
from t2m_core.errors import T2MError

MOVABLE = frozenset({ObjectKind.BOX, ObjectKind.HOOK})
"""Types a robot can grasp."""
UNMOVABLE = frozenset({ObjectKind.TABLE, ObjectKind.RACK})
"""Supports that never move."""
BOX = frozenset({ObjectKind.BOX})
TOOL = frozenset({ObjectKind.HOOK})
RECEPTACLE = frozenset({ObjectKind.RACK})


class SkillError(T2MError, ValueError):
    """A skill call that cannot be parsed, names an unknown skill or object, or has the wrong
    number or types of arguments."""


@dataclass(frozen=True)
class SkillParameter:
    """One argument of a skill.

    Attributes:
        name: its name in the signature the language model reads (``"a"``, ``"hook"``).
        kinds: object types it accepts (symbolic validity).
        role: a few words for error messages (``"a movable object"``).
    """

    name: str
    kinds: frozenset[ObjectKind]
    role: str


@dataclass(frozen=True)
class SkillSignature:
    """A skill's language-level signature, e.g. ``place(a, b)``."""

    name: str
    parameters: tuple[SkillParameter, ...]
    summary: str

    @property
    def arity(self) -> int:
        """Number of arguments."""
        return len(self.parameters)

    def __str__(self) -> str:
        return f"{self.name}({', '.join(p.name for p in self.parameters)})"


SKILLS: dict[str, SkillSignature] = {
    s.name: s
    for s in (
        # One argument everywhere (docs/guide/deviations.md#skills-by-name-pick-with-one-argument): the support object is not an argument of pick.
        SkillSignature(
            "pick", (SkillParameter("a", MOVABLE, "a movable object (box or hook)"),), "grasp a and lift it"
        ),
        SkillSignature(
            "place",
            (
                SkillParameter("a", MOVABLE, "a movable object (box or hook)"),
                SkillParameter("b", UNMOVABLE, "a support (table or rack)"),
            ),
            "put the held a onto b",
        ),
        SkillSignature(
            "pull",
            (SkillParameter("a", BOX, "a box"), SkillParameter("hook", TOOL, "the tool (hook)")),
            "pull a toward the robot with the held hook",
        ),
        SkillSignature(
            "push",
            (
                SkillParameter("a", BOX, "a box"),
                SkillParameter("hook", TOOL, "the tool (hook)"),
                SkillParameter("rack", RECEPTACLE, "a receptacle (rack)"),
            ),
            "push a away from the robot, under the rack, with the held hook",
        ),
    )
}
"""The four TableEnv skills, in the order the prompts list them (index by name, never position)."""

STOP = SkillSignature("stop", (), "end the episode (myopic baselines only)")
"""``stop()``, accepted by the parsers only with ``allow_stop=True``."""


@dataclass(frozen=True, order=True)
class SkillCall:
    """A grounded skill, e.g. ``place(red_box, rack)``."""

    name: str
    args: tuple[str, ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "args", tuple(self.args))

    def __str__(self) -> str:
        return f"{self.name}({', '.join(self.args)})"

    @property
    def lifted(self) -> str:
        """The call with each argument replaced by its object kind: ``place(box, rack)`` for
        ``place(red_box, rack)``, ``pull(box, hook)`` for ``pull(cyan_box, hook)``; raises
        ``KeyError`` for an unknown object."""
        return f"{self.name}({', '.join(object_spec(arg).kind.value for arg in self.args)})"

    @property
    def signature(self) -> SkillSignature:
        """The skill's signature; raises :class:`SkillError` for an unknown skill."""
        if self.name == STOP.name:
            return STOP
        try:
            return SKILLS[self.name]
        except KeyError:
            raise SkillError(f"unknown skill {self.name!r} in {self}", f"use one of: {', '.join(SKILLS)}") from None


# --------------------------------------------------------------------------------------------------
# Parsing and validity
# --------------------------------------------------------------------------------------------------


def parse_skill_call(text: str, object_names: Sequence[str] | None = None, *, allow_stop: bool = False) -> SkillCall:
    """Parse ``"place(red_box,rack)"`` into a :class:`SkillCall` (INST, docs/guide/planners.md#shared-steps).

    The skill name is lower-cased; spacing is free. Checks the skill exists, the number of
    arguments, that arguments are not repeated and, given ``object_names``, that every argument is a
    scene object. Argument *types* are not checked here (``pick(table)`` parses; the Q-values and the
    OOD detector judge it): see :func:`check_argument_types`.

    Raises:
        SkillError: naming the problem and the valid choices.
    """
    try:
        name, args = parse_call(text, "skill call")
    except LiteralSyntaxError as error:
        raise SkillError(f"cannot parse the skill call: {error.message}", error.hint) from None
    call = SkillCall(name.lower(), args)
    problems = syntax_problems(call, object_names, allow_stop=allow_stop)
    if problems:
        raise SkillError(f"invalid skill call {call}: {'; '.join(problems)}", signature_hint(allow_stop))
    return call


def parse_skill_sequence(
    text: str,
    object_names: Sequence[str] | None = None,
    *,
    allow_stop: bool = False,
    extract: bool = False,
) -> tuple[SkillCall, ...]:
    """Parse a Python/JSON list of skill-call strings, e.g. ``"['pick(a)', 'place(a, rack)']"``.

    Args:
        text: the list (quotes, whitespace, trailing commas and a code fence are accepted).
        object_names: the scene's objects, to check arguments against.
        allow_stop: accept ``stop()``.
        extract: take the first bracketed list out of surrounding prose.

    Raises:
        SkillError: naming the offending entry.
    """
    try:
        value = parse_string_lists(extract_first_list(text) if extract else text)
    except LiteralSyntaxError as error:
        hint = "write e.g. ['pick(a)', 'place(a, b)']"
        raise SkillError(f"cannot parse the skill sequence: {error.message}", hint) from None
    return _parse_entries(value, object_names, allow_stop)


def _parse_entries(entries: Sequence[object], object_names: Sequence[str] | None, allow_stop: bool = False) -> tuple[SkillCall, ...]:
    """Each entry through :func:`parse_skill_call`; an error names the entry's 1-based position."""
    calls = []
    for index, entry in enumerate(entries, start=1):
        if not isinstance(entry, str):
            raise SkillError(f"skill sequence entry {index} is a list; expected a skill-call string")
        try:
            calls.append(parse_skill_call(entry, object_names, allow_stop=allow_stop))
        except SkillError as error:
            raise SkillError(f"skill sequence entry {index}: {error.message}", error.hint) from None
    return tuple(calls)


def parse_skeleton(text: str, object_names: Sequence[str] | None = None) -> tuple[SkillCall, ...]:
    """Parse a skeleton as people type it, ``"pick(hook), pull(blue_box, hook)"``: calls unquoted,
    split at the commas outside parentheses.

    Raises:
        SkillError: an empty skeleton, or an entry that :func:`parse_skill_call` refuses.
    """
    calls, depth, current = [], 0, ""
    for char in text:
        depth += (char == "(") - (char == ")")
        if char == "," and depth == 0:
            calls.append(current.strip())
            current = ""
        else:
            current += char
    calls.append(current.strip())
    calls = [c for c in calls if c]
    if not calls:
        raise SkillError("empty skeleton", 'write e.g. "pick(hook), pull(blue_box, hook)"')
    return _parse_entries(calls, object_names)


def format_skill_sequence(calls: Iterable[SkillCall]) -> str:
    """``['pick(a)', 'place(a, b)']``, as the prompts write it."""
    return format_string_list([str(c) for c in calls])


def signature_hint(allow_stop: bool) -> str:
    signatures = [str(s) for s in SKILLS.values()] + ([str(STOP)] if allow_stop else [])
    return f"available skills: {', '.join(signatures)}"


def syntax_problems(
    call: SkillCall, object_names: Sequence[str] | None = None, *, allow_stop: bool = False
) -> list[str]:
    """What makes ``call`` syntactically invalid (unknown skill, arity, repeated or unknown
    arguments); empty when it is fine."""
    if call.name == STOP.name and allow_stop:
        return [] if not call.args else ["stop() takes no arguments"]
    if call.name not in SKILLS:
        return [f"unknown skill {call.name!r}"]
    signature = SKILLS[call.name]
    problems = []
    if len(call.args) != signature.arity:
        problems.append(f"{call.name} takes {signature.arity} argument(s) ({signature}), got {len(call.args)}")
    repeated = sorted({a for a in call.args if call.args.count(a) > 1})
    if repeated:
        problems.append(f"repeated argument(s) {', '.join(repeated)}")
    if object_names is not None:
        unknown = [a for a in call.args if a not in object_names]
        if unknown:
            problems.append(f"unknown object(s) {', '.join(unknown)}; scene objects: {', '.join(object_names)}")
    return problems


def check_argument_types(call: SkillCall) -> list[str]:
    """Argument-type problems of a syntactically valid call, e.g.
    ``["pick: table is not a movable object (box or hook)"]``; empty when the types fit."""
    problems = []
    for arg, parameter in zip(call.args, call.signature.parameters):
        kind = OBJECTS[arg].kind if arg in OBJECTS else None
        if kind not in parameter.kinds:
            problems.append(f"{call.name}: {arg} is not {parameter.role}")
    return problems


def validate_skill_call(call: SkillCall, object_names: Sequence[str], *, check_types: bool = True) -> None:
    """Raise :class:`SkillError` listing every syntax (and, by default, argument-type) problem."""
    problems = syntax_problems(call, object_names)
    if not problems and check_types:
        problems = check_argument_types(call)
    if problems:
        raise SkillError(f"invalid skill call {call}: {'; '.join(problems)}", signature_hint(False))
