"""``t2m skills ...``: inspect a skill library (a thin layer over the library plugin's reporter)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from t2m_core.errors import T2MError


def report(
    episodes: Annotated[int, typer.Option("--episodes", min=0, help="Simulated policy episodes per skill (0: none).")] = 20,
    data: Annotated[Path | None, typer.Option("--data", help="Dataset directory (validation splits) for the Q, dynamics and size figures.")] = None,
    checkpoints: Annotated[Path | None, typer.Option("--checkpoints", help="Checkpoints directory (default: the shipped ones).")] = None,
    ood_detectors: Annotated[
        Path | None,
        typer.Option("--ood-detectors", help="Checkpoints directory whose calibrated Q-ensembles detect out-of-distribution calls "
                     "instead of the library's own (default: the checkpoints directory's ood_detectors/ when it has one)."),
    ] = None,
    published_ood: Annotated[
        bool, typer.Option("--published-ood", help="Report each Q-ensemble's own OOD detection (the published detector), ignoring detectors.")
    ] = False,
    out: Annotated[Path, typer.Option("--out", help="Where report.json, report.md and the plots go.")] = Path("skills-report"),
    library: Annotated[str, typer.Option("--library", help="Skill library plugin.")] = "tableenv",
    sim: Annotated[str, typer.Option("--sim", help="Simulator plugin for the policy episodes.")] = "mujoco",
    as_json: Annotated[bool, typer.Option("--json", help="Print the report as JSON on stdout.")] = False,
) -> None:
    """Measure the skill library: Q precision / recall / reliability, policy success in simulated
    evaluation scenes, dynamics error, OOD rates, dataset sizes."""
    from rich.console import Console

    from t2m_core.cli.train_cmd import library_entry
    from t2m_core.registry import get_registry

    if published_ood and ood_detectors is not None:
        raise T2MError("--published-ood and --ood-detectors exclude each other", "pass one of them: the Q-ensembles detect, or the detectors do")
    reporter = library_entry(library, "reporter")
    spec = get_registry().get("skill_library", library)
    if checkpoints is None:  # the library's own default location
        checkpoints = getattr(spec.options(), "checkpoint_directory", None)
    if checkpoints is None:
        raise T2MError(f"the skill library {spec.name!r} has no default checkpoints", "pass --checkpoints DIR")
    simulator = get_registry().create("simulator", sim) if episodes > 0 else None
    console = Console(stderr=True)
    try:
        with console.status(f"measuring the {spec.name} skills ({episodes} simulated episodes each)..."):
            # libraries without separate detectors keep the four-argument reporter
            extra = {k: v for k, v in (("ood_detectors", ood_detectors), ("published_ood", published_ood)) if v}
            result = reporter(checkpoints, data, episodes, out, simulator, **extra)
    finally:
        if simulator is not None:
            simulator.close()
    console.print((out / "report.md").read_text(), highlight=False)
    if as_json:
        typer.echo(json.dumps(result, indent=2))


def register(app: typer.Typer) -> None:
    """Add ``t2m skills`` to the root app."""
    skills_app = typer.Typer(help="Skill library commands.", no_args_is_help=True)
    skills_app.command("report")(report)
    app.add_typer(skills_app, name="skills")
