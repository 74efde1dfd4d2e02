"""mkdocs hook: fills the reference pages from the code, so they cannot drift from it.

A page includes a generated block with a marker line ``<!-- t2m:NAME -->``:

- ``cli``: every ``t2m`` command with its options (from the typer app);
- ``config-defaults``: the default run configuration as YAML;
- ``config-keys``: every run-config key with type, default and description (from the pydantic models);
- ``config-schema``: the full JSON schema;
- ``hooks``: every hook specification with its docstring (from ``t2m_core.hookspecs``);
- ``plugins``: the components registered by the installed plugins, with their options.
"""

from __future__ import annotations

import inspect
import json
import re
from typing import Any

MARKER = re.compile(r"^<!-- t2m:([a-z-]+) -->$", re.MULTILINE)


def on_page_markdown(markdown: str, **_: Any) -> str:
    """Replace each marker line with its generated Markdown."""
    return MARKER.sub(lambda match: GENERATORS[match.group(1)](), markdown)


def cli_reference() -> str:
    import typer

    from t2m_core.cli.main import app

    sections: list[str] = []

    def visit(command: Any, path: list[str]) -> None:
        # duck-typed: typer's command classes need not subclass the installed click's
        subcommands = getattr(command, "commands", None)
        if subcommands is None or len(path) == 1:
            sections.append(_command_section(command, path))
        for name in sorted(subcommands or {}):
            visit(subcommands[name], [*path, name])

    visit(typer.main.get_command(app), ["t2m"])
    return "\n".join(sections)


def _command_section(command: Any, path: list[str]) -> str:
    context = _context_for(command, path)
    usage = " ".join(command.collect_usage_pieces(context))
    lines = [f"### `{' '.join(path)}`", "", inspect.cleandoc(command.help or ""), ""]
    lines += ["```text", f"{' '.join(path)} {usage}", "```", ""]
    params = [param for param in command.params if not getattr(param, "hidden", False)]
    if params:
        lines += ["| Argument or option | Type | Default | Meaning |", "|---|---|---|---|"]
        for option in params:
            if option.param_type_name == "argument":
                names = f"`{option.name.upper()}` (argument)"
            else:
                names = ", ".join(f"`{name}`" for name in option.opts)
            kind = "flag" if getattr(option, "is_flag", False) else _type_name(option, context)
            repeatable = " (repeatable)" if option.multiple else ""
            default = "" if option.default in (None, False, ()) or kind == "flag" else f"`{option.default}`"
            lines.append(f"| {names} | {kind}{repeatable} | {default} | {getattr(option, 'help', None) or ''} |")
        lines.append("")
    return "\n".join(lines)


def _type_name(option: Any, context: Any) -> str:
    display = getattr(option, "display_type", None)  # typer's own parameters
    name = display(context) if display is not None else option.type.name
    return name.strip("<>").replace("|", "\\|")


def _context_for(command: Any, path: list[str]) -> Any:
    context_class = getattr(command, "context_class", None)
    if context_class is None:
        import click

        context_class = click.Context
    return context_class(command, info_name=" ".join(path))


def config_defaults() -> str:
    from t2m_core.config import RunConfig, config_to_yaml

    return f"```yaml\n{config_to_yaml(RunConfig())}```\n"


def config_keys() -> str:
    from t2m_core.config import run_config_schema

    schema = run_config_schema()
    definitions = schema.get("$defs", {})
    rows = ["| Key | Type | Default | Meaning |", "|---|---|---|---|"]

    def resolve(node: dict[str, Any]) -> dict[str, Any] | None:
        """The object definition behind a property, following $ref and `X | None`."""
        for candidate in [node, *node.get("anyOf", []), *node.get("allOf", [])]:
            if "$ref" in candidate:
                return definitions[candidate["$ref"].rsplit("/", 1)[-1]]
        return None

    def type_of(node: dict[str, Any]) -> str:
        if "anyOf" in node:
            return " or ".join(type_of(option) for option in node["anyOf"])
        if "$ref" in node:
            return "mapping"
        return {"object": "mapping", "array": "list"}.get(node.get("type", "any"), node.get("type", "any"))

    def walk(properties: dict[str, Any], prefix: str) -> None:
        for key, node in properties.items():
            path = f"{prefix}{key}"
            default = json.dumps(node["default"]) if "default" in node else ""
            description = node.get("description", "")
            target = resolve(node)
            rows.append(
                f"| `{path}` | {type_of(node)} | {default and f'`{default}`'} | {description or (target or {}).get('description', '')} |"
            )
            if target is not None and "properties" in target:
                walk(target["properties"], f"{path}.")

    walk(schema["properties"], "")
    return "\n".join(rows) + "\n"


def config_schema() -> str:
    from t2m_core.config import run_config_schema

    return f"```json\n{json.dumps(run_config_schema(), indent=2)}\n```\n"


def hooks_reference() -> str:
    from t2m_core import hookspecs

    sections = []
    for kind, hook_name in hookspecs.REGISTRATION_HOOKS.items():
        function = getattr(hookspecs, hook_name)
        signature = inspect.signature(function)
        summary, _, body = inspect.cleandoc(function.__doc__ or "").partition("\n")
        sections.append(
            f"### `{hook_name}{signature}`\n\nComponent kind: `{kind}`. {summary}\n\n{_indented_blocks_to_fences(body)}\n"
        )
    return "\n".join(sections)


def _indented_blocks_to_fences(text: str) -> str:
    """Turn reST ``Example::`` + indented code into a fenced Python block."""
    head, separator, code = text.partition("::\n")
    if not separator:
        return text
    return f"{head.strip()}:\n\n```python\n{inspect.cleandoc(code)}\n```"


def plugins_reference() -> str:
    from t2m_core.registry import get_registry

    entries = get_registry().components()
    rows = ["| Kind | Name | Aliases | Provider | Summary |", "|---|---|---|---|---|"]
    for entry in entries:
        aliases = ", ".join(f"`{alias}`" for alias in entry.spec.aliases)
        rows.append(
            f"| {entry.kind} | `{entry.spec.name}` | {aliases} | {entry.plugin.provider} | {entry.spec.summary} |"
        )
    sections = ["\n".join(rows), ""]
    for entry in entries:
        sections += [f"### {entry.kind.replace('_', ' ')} `{entry.spec.name}`", "", entry.spec.summary, ""]
        sections.append(_options_table(entry.spec.options.model_json_schema()))
    return "\n".join(sections) + "\n"


def _options_table(schema: dict[str, Any]) -> str:
    """Markdown table of a component's options (name, type, default, meaning), from its JSON schema."""
    properties = schema.get("properties", {})
    if not properties:
        return "No options.\n"
    rows = ["| Option | Type | Default | Meaning |", "|---|---|---|---|"]
    for name, node in properties.items():
        options = node.get("anyOf", [node])
        kinds = [
            " or ".join(f"`{json.dumps(value)}`" for value in option["enum"])
            if "enum" in option
            else option.get("type", "any")
            for option in options
        ]
        kind = " or ".join(kinds).replace("|", "\\|")
        default = f"`{json.dumps(node['default'])}`" if "default" in node else "required"
        description = node.get("description", "").replace("|", "\\|").replace("\n", " ")
        rows.append(f"| `{name}` | {kind} | {default} | {description} |")
    return "\n".join(rows) + "\n"


GENERATORS = {
    "cli": cli_reference,
    "config-defaults": config_defaults,
    "config-keys": config_keys,
    "config-schema": config_schema,
    "hooks": hooks_reference,
    "plugins": plugins_reference,
}
