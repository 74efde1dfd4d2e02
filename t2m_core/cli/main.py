"""Entry point of the ``t2m`` console script: assembles the command groups.

Each command group lives in its own module and imports heavy libraries only inside its commands,
so ``t2m --help`` stays fast.
"""

from __future__ import annotations

import typer

from t2m_core.cli import config_cmd, llm_cmd, plugins_cmd, sim_cmd, tasks_cmd

app = typer.Typer(
    name="t2m",
    help="Turn natural-language instructions into geometrically verified robot plans (Text2Motion).",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)

plugins_cmd.register(app)
config_cmd.register(app)
tasks_cmd.register(app)
sim_cmd.register(app)
llm_cmd.register(app)


def main() -> None:
    """Console-script entry point."""
    app()


if __name__ == "__main__":
    main()
