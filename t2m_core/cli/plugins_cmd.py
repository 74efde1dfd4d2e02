"""``t2m list-plugins``: every component, the plugin that provides it, and plugins that failed."""

from __future__ import annotations

import json
from typing import Annotated, Any

import typer


def plugin_rows() -> list[dict[str, Any]]:
    """One row per registered component, plus one per plugin that failed or provides nothing.

    Keys: ``kind, name, aliases, provider, version, status, summary, plugin, builtin``; ``kind`` is
    ``None`` for a plugin row that has no component (a failed one, typically).
    """
    from t2m_core.registry import get_registry

    registry = get_registry()
    rows = [
        {
            "kind": entry.kind,
            "name": entry.spec.name,
            "aliases": list(entry.spec.aliases),
            "provider": entry.plugin.provider,
            "version": entry.plugin.version,
            "status": entry.plugin.status,
            "summary": entry.spec.summary,
            "plugin": entry.plugin.name,
            "builtin": entry.plugin.builtin,
        }
        for entry in registry.components()
    ]
    providing = {row["plugin"] for row in rows}
    rows.extend(
        {
            "kind": None,
            "name": record.name,
            "aliases": [],
            "provider": record.provider,
            "version": record.version,
            "status": record.status if record.error else "ok (registers no component)",
            "summary": record.module,
            "plugin": record.name,
            "builtin": record.builtin,
        }
        for record in registry.plugins
        if record.name not in providing
    )
    return rows


def list_plugins(
    as_json: Annotated[bool, typer.Option("--json", help="Print a JSON array of rows on stdout.")] = False,
) -> None:
    """List every component (kind, name, aliases, provider distribution and version, status).

    A plugin that fails to import is listed as failed with its error; the exit status stays 0.
    T2M_DISABLE_PLUGIN_AUTOLOAD=1 lists the builtins only; T2M_PLUGINS=pkg.hooks adds modules by name.
    """
    rows = plugin_rows()
    if as_json:
        typer.echo(json.dumps(rows, indent=2))
        return
    _print_table(rows)


def _print_table(rows: list[dict[str, Any]]) -> None:
    """A table of components; the errors of failed plugins follow it in full."""
    from rich.console import Console
    from rich.table import Table
    from rich.text import Text

    table = Table(title="t2m plugins", title_justify="left")
    for column in ("kind", "name", "aliases", "provider", "status"):
        table.add_column(column, overflow="fold")
    failures = []
    for row in rows:
        ok = row["status"].startswith("ok")
        if not ok:
            failures.append(row)
        provider = f"{row['provider']} {row['version']}".strip()
        cells = (row["kind"] or "(plugin)", row["name"], ", ".join(row["aliases"]), provider)
        table.add_row(*(Text(cell) for cell in cells), Text("ok" if ok else "failed", style="green" if ok else "red"))
    console = Console()
    console.print(table)
    for row in failures:
        console.print(
            Text.assemble((f"{row['name']}", "bold red"), f" ({row['provider']}): {row['status']}"), soft_wrap=True
        )


def register(app: typer.Typer) -> None:
    """Add ``list-plugins`` to the root app."""
    app.command("list-plugins")(list_plugins)
