"""Entry point of the ``t2m`` console script: assembles the command groups.

Each command group lives in its own module and imports heavy libraries only inside its commands,
so ``t2m --help`` stays fast. A :class:`~t2m_core.errors.T2MError` raised by any command is printed
as its message and hint on stderr, without a traceback, and exits with status 2.
"""

from __future__ import annotations

from typing import Annotated, Any

import click
import typer
from typer.core import TyperGroup

from t2m_core.cli import config_cmd, datagen_cmd, eval_cmd, llm_cmd, plan_cmd, plugins_cmd, run_cmd, show_cmd, sim_cmd, skills_cmd, tasks_cmd, train_cmd
from t2m_core.errors import T2MError

USER_ERROR_EXIT_CODE = 2


class _UserErrorGroup(TyperGroup):
    """Root command group that renders user-facing errors instead of tracebacks."""

    def invoke(self, ctx: click.Context) -> Any:
        try:
            return super().invoke(ctx)
        except T2MError as error:
            render_error(error)
            raise typer.Exit(USER_ERROR_EXIT_CODE) from None


def render_error(error: T2MError) -> None:
    """Print ``error``'s message and hint on stderr."""
    from rich.console import Console
    from rich.markup import escape

    console = Console(stderr=True)
    # soft_wrap: the terminal wraps long lines; rich would break paths and names apart
    console.print(f"[bold red]Error:[/] {escape(error.message)}", highlight=False, soft_wrap=True)
    if error.hint:
        console.print(f"[bold]Hint:[/] {escape(error.hint)}", highlight=False, soft_wrap=True)


app = typer.Typer(
    name="t2m",
    cls=_UserErrorGroup,
    help="Turn natural-language instructions into geometrically verified robot plans (Text2Motion).",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)


def _print_version(value: bool) -> None:
    if value:
        from t2m_core import __version__

        typer.echo(f"t2m {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: Annotated[
        bool,
        typer.Option("--version", callback=_print_version, is_eager=True, help="Print the version and exit."),
    ] = False,
) -> None:
    """Turn natural-language instructions into geometrically verified robot plans (Text2Motion)."""


plugins_cmd.register(app)
config_cmd.register(app)
tasks_cmd.register(app)
sim_cmd.register(app)
llm_cmd.register(app)
datagen_cmd.register(app)
train_cmd.register(app)
skills_cmd.register(app)
plan_cmd.register(app)
run_cmd.register(app)
show_cmd.register(app)
eval_cmd.register(app)


def main() -> None:
    """Console-script entry point."""
    app()


if __name__ == "__main__":
    main()
