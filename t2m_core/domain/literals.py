"""Strict parsers for the two text forms of the symbolic layer: calls (``on(red_box, rack)``,
``place(red_box, table)``) and Python/JSON lists of strings (``[['on(a, b)'], ["inhand(c)"]]``).

Hand-written grammars; nothing is ever evaluated. Errors quote the text and point at the offending
position, so a language-model answer or a task file can be fixed from the message alone.
"""

from __future__ import annotations

import re

from t2m_core.errors import T2MError

_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_FENCE = re.compile(r"^\s*```[A-Za-z0-9_+-]*[ \t]*\n?(.*?)\n?\s*```\s*$", re.DOTALL)


class LiteralSyntaxError(T2MError, ValueError):
    """Text that does not follow the grammar.

    Attributes:
        text: the text that was parsed.
        position: index of the offending character in ``text``.
    """

    def __init__(self, problem: str, text: str, position: int, hint: str | None = None) -> None:
        self.text = text
        self.position = position
        snippet, caret = _excerpt(text, position)
        super().__init__(f"{problem} at position {position}:\n  {snippet}\n  {caret}", hint)


def _excerpt(text: str, position: int, width: int = 60) -> tuple[str, str]:
    """A one-line window of ``text`` around ``position`` and a caret line under it."""
    start = max(0, position - width // 2)
    window = text[start : start + width].replace("\n", " ")
    prefix = "…" if start > 0 else ""
    suffix = "…" if start + width < len(text) else ""
    return f"{prefix}{window}{suffix}", " " * (len(prefix) + position - start) + "^"


def strip_code_fences(text: str) -> str:
    """Remove surrounding whitespace and one enclosing Markdown code fence (```python … ```)."""
    match = _FENCE.match(text)
    return (match.group(1) if match else text).strip()


# --------------------------------------------------------------------------------------------------
# Calls: name(arg, arg, ...)
# --------------------------------------------------------------------------------------------------


def parse_call(text: str, what: str = "proposition") -> tuple[str, tuple[str, ...]]:
    """Parse ``name(arg1, arg2, ...)`` with identifiers for the name and every argument.

    Whitespace around tokens is allowed; nothing may follow the closing parenthesis.

    Args:
        text: the call, e.g. ``"on(red_box,rack)"``.
        what: the kind of call, used in error messages (``"proposition"``, ``"skill call"``).

    Returns:
        ``(name, args)``, e.g. ``("on", ("red_box", "rack"))``.

    Raises:
        LiteralSyntaxError: naming the position of the first offending character.
    """
    example = "on(red_box, rack)" if what == "proposition" else "place(red_box, rack)"
    hint = f"write a {what} as name(arg, ...), e.g. {example}"
    pos = _skip_space(text, 0)
    match = _IDENTIFIER.match(text, pos)
    if not match:
        raise LiteralSyntaxError(f"expected the {what}'s name", text, pos, hint)
    name = match.group()
    pos = _skip_space(text, match.end())
    if pos >= len(text) or text[pos] != "(":
        raise LiteralSyntaxError(f"expected '(' after {name!r}", text, pos, hint)
    pos = _skip_space(text, pos + 1)
    args: list[str] = []
    if pos < len(text) and text[pos] == ")":
        pos += 1
    else:
        while True:
            match = _IDENTIFIER.match(text, pos)
            if not match:
                raise LiteralSyntaxError("expected an object name", text, pos, hint)
            args.append(match.group())
            pos = _skip_space(text, match.end())
            if pos < len(text) and text[pos] == ",":
                pos = _skip_space(text, pos + 1)
                continue
            if pos < len(text) and text[pos] == ")":
                pos += 1
                break
            raise LiteralSyntaxError("expected ',' or ')'", text, pos, hint)
    pos = _skip_space(text, pos)
    if pos != len(text):
        raise LiteralSyntaxError(f"unexpected text after the {what}", text, pos, hint)
    return name, tuple(args)


def format_call(name: str, args: tuple[str, ...]) -> str:
    """The canonical spelling ``name(a, b)``: one space after each comma."""
    return f"{name}({', '.join(args)})"


def _skip_space(text: str, pos: int) -> int:
    while pos < len(text) and text[pos].isspace():
        pos += 1
    return pos


# --------------------------------------------------------------------------------------------------
# Lists of strings
# --------------------------------------------------------------------------------------------------

NestedStrings = list["str | NestedStrings"]


def parse_string_lists(text: str) -> NestedStrings:
    """Parse a Python/JSON list literal whose leaves are quoted strings.

    Accepts single or double quotes, any whitespace, trailing commas and one enclosing code fence.
    Escapes inside strings are ``\\\\``, ``\\'`` and ``\\"``; anything else (numbers, names, tuples,
    dicts) is rejected.

    Raises:
        LiteralSyntaxError: naming the position of the first offending character.
    """
    body = strip_code_fences(text)
    value, pos = _parse_list(body, _skip_space(body, 0))
    pos = _skip_space(body, pos)
    if pos != len(body):
        raise LiteralSyntaxError("unexpected text after the list", body, pos, "answer with the list only")
    return value


def _parse_list(text: str, pos: int) -> tuple[NestedStrings, int]:
    if pos >= len(text) or text[pos] != "[":
        raise LiteralSyntaxError("expected '['", text, pos, "write a Python list, e.g. ['on(a, b)']")
    items: NestedStrings = []
    pos = _skip_space(text, pos + 1)
    while True:
        if pos >= len(text):
            raise LiteralSyntaxError("unterminated list: expected ']'", text, pos)
        char = text[pos]
        if char == "]":
            return items, pos + 1
        if char == "[":
            item, pos = _parse_list(text, pos)
        elif char in "'\"":
            item, pos = _parse_string(text, pos)
        else:
            raise LiteralSyntaxError("expected a quoted string or a nested list", text, pos)
        items.append(item)
        pos = _skip_space(text, pos)
        if pos < len(text) and text[pos] == ",":
            pos = _skip_space(text, pos + 1)
        elif pos < len(text) and text[pos] != "]":
            raise LiteralSyntaxError("expected ',' or ']'", text, pos)


def _parse_string(text: str, pos: int) -> tuple[str, int]:
    quote = text[pos]
    chars: list[str] = []
    i = pos + 1
    while i < len(text):
        char = text[i]
        if char == "\\" and i + 1 < len(text) and text[i + 1] in "\\'\"":
            chars.append(text[i + 1])
            i += 2
            continue
        if char == "\\":
            raise LiteralSyntaxError("unsupported escape in a string", text, i)
        if char == "\n":
            break
        if char == quote:
            return "".join(chars), i + 1
        chars.append(char)
        i += 1
    raise LiteralSyntaxError(f"unterminated string: expected a closing {quote}", text, pos)


def extract_first_list(text: str) -> str:
    """The first balanced ``[...]`` in free text (brackets inside quoted strings are ignored), as
    language-model answers often wrap the list in prose (docs/guide/prompts.md#parsing-and-validation).

    Raises:
        LiteralSyntaxError: when no ``[`` exists or the first list is never closed.
    """
    start = text.find("[")
    if start < 0:
        raise LiteralSyntaxError("no list found", text, 0, "the answer must contain a Python list")
    depth, quote, i = 0, "", start
    while i < len(text):
        char = text[i]
        if quote:
            if char == "\\":
                i += 1
            elif char == quote or char == "\n":
                quote = ""
        elif char in "'\"":
            quote = char
        elif char == "[":
            depth += 1
        elif char == "]":
            depth -= 1
            if depth == 0:
                return text[start : i + 1]
        i += 1
    raise LiteralSyntaxError("the first list is never closed", text, start)


def format_string_list(items: list[str] | tuple[str, ...]) -> str:
    """Python spelling with single quotes, as the prompts use: ``['a', 'b']``."""
    return "[" + ", ".join(_quote(item) for item in items) + "]"


def _quote(item: str) -> str:
    return "'" + item.replace("\\", "\\\\").replace("'", "\\'") + "'"
