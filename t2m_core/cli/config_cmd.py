"""``t2m config show|validate|schema``: the resolved run configuration, its problems, its schema."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any, Optional

import typer

config_app = typer.Typer(
    name="config",
    help="Show, validate and describe run configurations.",
    no_args_is_help=True,
)

ConfigFiles = Annotated[
    Optional[list[Path]],  # noqa: UP045 - typer needs Optional here
    typer.Option("--config", "-c", help="Config file (YAML); repeat to merge several, later ones win."),
]
Planner = Annotated[Optional[str], typer.Option("--planner", help="Task planner name (task_planner.name).")]  # noqa: UP045
Sim = Annotated[Optional[str], typer.Option("--sim", help="Simulator name (simulator.name).")]  # noqa: UP045
Llm = Annotated[Optional[str], typer.Option("--llm", help="Language model name or alias (language_model.name).")]  # noqa: UP045
Task = Annotated[Optional[str], typer.Option("--task", help="Task name (task).")]  # noqa: UP045
Seed = Annotated[Optional[int], typer.Option("--seed", help="Base seed (seed).")]  # noqa: UP045
Overrides = Annotated[
    Optional[list[str]],  # noqa: UP045
    typer.Option("--set", help="Override any key, e.g. --set simulator.options.substeps=8 (value parsed as YAML)."),
]
AsJson = Annotated[bool, typer.Option("--json", help="Print JSON on stdout.")]


def _sources(
    planner: str | None, sim: str | None, llm: str | None, task: str | None, seed: int | None
) -> dict[str, Any]:
    return {"planner": planner, "sim": sim, "llm": llm, "task": task, "seed": seed}


@config_app.command("show")
def show(
    config: ConfigFiles = None,
    planner: Planner = None,
    sim: Sim = None,
    llm: Llm = None,
    task: Task = None,
    seed: Seed = None,
    overrides: Overrides = None,
    as_json: AsJson = False,
) -> None:
    """Print the fully resolved run configuration (defaults < --config files < named flags < --set).

    Component options are filled in from each plugin's options model.
    """
    from t2m_core.config import config_to_yaml, resolve_config
    from t2m_core.registry import get_registry

    resolved = resolve_config(
        config or [], flags=_sources(planner, sim, llm, task, seed), overrides=overrides or [], registry=get_registry()
    )
    if as_json:
        typer.echo(json.dumps(resolved.model_dump(mode="json"), indent=2))
    else:
        typer.echo(config_to_yaml(resolved), nl=False)


@config_app.command("validate")
def validate(
    config: ConfigFiles = None,
    planner: Planner = None,
    sim: Sim = None,
    llm: Llm = None,
    task: Task = None,
    seed: Seed = None,
    overrides: Overrides = None,
    as_json: AsJson = False,
) -> None:
    """Check a run configuration and report every problem with its YAML path (exit status 1 if any)."""
    from rich.console import Console
    from rich.markup import escape

    from t2m_core.config import check_config
    from t2m_core.registry import get_registry

    _, issues = check_config(
        config or [], flags=_sources(planner, sim, llm, task, seed), overrides=overrides or [], registry=get_registry()
    )
    if as_json:
        errors = [{"path": issue.path, "message": issue.message, "source": issue.source} for issue in issues]
        typer.echo(json.dumps({"valid": not issues, "errors": errors}, indent=2))
    else:
        console = Console(stderr=True)
        for issue in issues:
            console.print(f"[red]✗[/] {escape(str(issue))}", highlight=False, soft_wrap=True)
        if not issues:
            console.print("[green]✓[/] configuration is valid", highlight=False, soft_wrap=True)
    if issues:
        raise typer.Exit(1)


@config_app.command("schema")
def schema() -> None:
    """Print the JSON schema of run configurations, including every installed component's options."""
    from t2m_core.config import run_config_schema
    from t2m_core.registry import get_registry

    typer.echo(json.dumps(run_config_schema(get_registry()), indent=2))


def register(app: typer.Typer) -> None:
    """Add the ``config`` group to the root app."""
    app.add_typer(config_app)
