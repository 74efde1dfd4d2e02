"""``t2m train`` and ``t2m calibrate``: train and calibrate a skill library's models through the entry
points its plugin registers (:class:`t2m_core.plugin_specs.SkillLibrarySpec`)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import typer

from t2m_core.errors import T2MError

SKILL_NAMES = ("pick", "place", "pull", "push")
MODEL_NAMES = ("q", "policy", "dynamics")
SHOWN_METRICS = ("loss", "train_anchor_loss", "exposure_variance", "precision", "recall", "q_min_mean", "simulated_success", "targets_searched")
"""The metrics a training's progress bar shows (``targets_searched``: the policy's searched targets, before its steps)."""


def _skills(skill: str) -> tuple[str, ...]:
    if skill == "all":
        return SKILL_NAMES
    if skill not in SKILL_NAMES:
        raise T2MError(f"unknown skill {skill!r}", f"use one of: {', '.join(SKILL_NAMES)}, all")
    return (skill,)


def library_entry(library: str, entry: str) -> Any:
    from t2m_core.plugin_specs import load_callable
    from t2m_core.registry import get_registry

    spec = get_registry().get("skill_library", library)
    target = getattr(spec, entry, None)
    if target is None:
        raise T2MError(f"the skill library {spec.name!r} has no {entry}", "choose a library that can be trained (see `t2m list-plugins`)")
    return load_callable(target, f"{entry} of skill library {spec.name!r}")


def train(
    skill: Annotated[str, typer.Option("--skill", help="pick, place, pull, push, or all.")],
    data: Annotated[Path, typer.Option("--data", help="Dataset directory written by `t2m datagen`.")],
    out: Annotated[Path, typer.Option("--out", help="Checkpoints directory (one sub-directory per skill).")],
    model: Annotated[str, typer.Option("--model", help="q, policy, dynamics, or all (in that order).")] = "all",
    library: Annotated[str, typer.Option("--library", help="Skill library plugin.")] = "tableenv",
    steps: Annotated[int | None, typer.Option("--steps", min=1, help="Optimiser steps per model (default: the library's).")] = None,
    eval_every: Annotated[int | None, typer.Option("--eval-every", min=1, help="Steps between validation evaluations.")] = None,
    learning_rate: Annotated[float | None, typer.Option("--learning-rate", min=0.0, help="Adam learning rate of every trained model (default: the library's).")] = None,
    train_size: Annotated[
        int | None, typer.Option("--train-size", min=1, help="Train on the first N training transitions only (learning curves).")
    ] = None,
    ensemble_batches: Annotated[
        str | None, typer.Option("--ensemble-batches", help="Q-ensemble batches: shared (published) or bootstrap.")
    ] = None,
    q_network: Annotated[
        str | None,
        typer.Option("--q-network", help="Q-ensemble network: mlp (published), relational (reads the other objects as a set) or geometric (also reads the primitive's geometric screen)."),
    ] = None,
    screen: Annotated[
        str | None,
        typer.Option("--screen", help="Geometric Q-ensemble: the screen predictions it reads, flags or margins, comma-separated "
                     "(default: the skill's; e.g. in_the_way,unreachable for Pull's flags instead of its margins)."),
    ] = None,
    dynamics_network: Annotated[
        str | None,
        typer.Option("--dynamics-network", help="Dynamics network: mlp (published), relational (reads the other objects as a set) or prior (corrects the primitive's geometric prediction)."),
    ] = None,
    policy_network: Annotated[
        str | None,
        typer.Option("--policy-network", help="Policy network: mlp (published) or geometric (also reads which gripper yaws the primitive's geometric screen rules out)."),
    ] = None,
    selection_episodes: Annotated[
        int | None,
        typer.Option("--selection-episodes", min=0, help="Simulated episodes selecting the policy at each evaluation (0: by the Q-ensemble)."),
    ] = None,
    policy_targets: Annotated[
        int | None,
        typer.Option("--policy-targets", min=0, help="Policy: rank the starting policy's action and this many noisy copies by min-of-8 Q "
                     "in every training state and pull the policy towards the best (0: the published actor objective alone)."),
    ] = None,
    policy_target_sigma: Annotated[
        float | None, typer.Option("--policy-target-sigma", min=0.0, help="Noise of those copies per action dimension (default 0.3).")
    ] = None,
    policy_target_weight: Annotated[
        float | None, typer.Option("--policy-target-weight", min=0.0, help="Weight of the distance to those targets against the actor loss (default 1).")
    ] = None,
    policy_target_value: Annotated[
        str | None, typer.Option("--policy-target-value", help="Rank those copies by the members' min (default, the actor's value) or mean.")
    ] = None,
    policy_target_margin: Annotated[
        float | None,
        typer.Option("--policy-target-margin", min=0.0, help="A copy replaces the policy's own action as the target only when valued this much higher (default 0)."),
    ] = None,
    policy_target_uniform: Annotated[
        float | None,
        typer.Option("--policy-target-uniform", min=0.0, max=1.0, help="Share of those copies drawn uniformly over the action box (default 0)."),
    ] = None,
    policy_target_tolerance: Annotated[
        float | None,
        typer.Option("--policy-target-tolerance", min=0.0,
                     help="Copies valued within this much of the best count as best; the nearest to the policy's action is the target (default 0)."),
    ] = None,
    policy_target_focus: Annotated[
        float | None,
        typer.Option("--policy-target-focus", min=0.0, max=0.99,
                     help="Share of each batch drawn from the states whose target moved from the policy's own action (default 0)."),
    ] = None,
    sim: Annotated[str, typer.Option("--sim", help="Simulator plugin of the policy-selection episodes.")] = "mujoco",
    more_train: Annotated[
        list[Path] | None,
        typer.Option("--more-train", help="Another dataset directory whose train split is appended to --data's (repeatable)."),
    ] = None,
    init_from: Annotated[
        Path | None,
        typer.Option("--init-from", help="Checkpoints directory whose weights start training (fine-tuning) instead of a fresh initialisation."),
    ] = None,
    anchor: Annotated[
        list[Path] | None,
        typer.Option("--anchor", help="A dataset directory whose train split the Q-ensemble learns from the --init-from ensemble's "
                     "predictions instead of its labels, so that fine-tuning keeps what it knew there (repeatable). With a --q-network "
                     "other than the --init-from ensemble's, a fresh network is distilled from it there."),
    ] = None,
    anchor_weight: Annotated[
        float | None, typer.Option("--anchor-weight", min=0.0, help="Weight of the anchor loss against the labelled loss (default 1).")
    ] = None,
    ood_exposure: Annotated[
        list[Path] | None,
        typer.Option("--ood-exposure", help="A dataset directory whose invalid split the Q-ensemble's members learn to disagree on, "
                     "so that the OOD detector flags such pairs (repeatable; calibrate on another invalid split)."),
    ] = None,
    exposure_weight: Annotated[
        float | None, typer.Option("--exposure-weight", min=0.0, help="Weight of the OOD exposure loss against the labelled loss (default 1).")
    ] = None,
    weight_average: Annotated[
        float | None,
        typer.Option("--weight-average", min=0.0, max=0.9999, help="Q-ensemble: evaluate, select and save an exponential moving "
                     "average of the weights with this decay per step (e.g. 0.999; default 0: the trained weights)."),
    ] = None,
    threads: Annotated[
        int | None,
        typer.Option("--threads", min=1, help="Torch / OpenMP threads of the training (default: all cores; 1 beside other busy jobs, "
                     "whose cores the idle threads would spin on)."),
    ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the results as JSON on stdout.")] = False,
) -> None:
    """Train a skill library's models on a dataset. Rerunning the same command after a kill resumes
    from the last evaluation."""
    if threads is not None:
        from t2m_core.executors.local import limit_threads

        limit_threads(threads)
    models = MODEL_NAMES if model == "all" else (model,)
    if model != "all" and model not in MODEL_NAMES:
        raise T2MError(f"unknown model {model!r}", f"use one of: {', '.join(MODEL_NAMES)}, all")
    trainer = library_entry(library, "trainer")
    chosen = (
        ("steps", steps), ("eval_every", eval_every), ("learning_rate", learning_rate), ("train_size", train_size), ("ensemble_batches", ensemble_batches),
        ("selection_episodes", selection_episodes), ("q_network", q_network), ("dynamics_network", dynamics_network), ("policy_network", policy_network), ("anchor_weight", anchor_weight),
        ("exposure_weight", exposure_weight), ("policy_targets", policy_targets), ("screen", _names(screen)), ("policy_target_sigma", policy_target_sigma),
        ("policy_target_weight", policy_target_weight), ("policy_target_value", policy_target_value), ("policy_target_margin", policy_target_margin),
        ("policy_target_uniform", policy_target_uniform), ("policy_target_focus", policy_target_focus),
        ("policy_target_tolerance", policy_target_tolerance), ("weight_average", weight_average),
    )
    overrides = {key: value for key, value in chosen if value is not None}
    results = {}
    for name in _skills(skill):
        results[name] = _train_with_progress(trainer, name, models, data, out / name, overrides, sim, tuple(more_train or ()), init_from,
                                             tuple(anchor or ()), tuple(ood_exposure or ()))
    if as_json:
        typer.echo(json.dumps(results, indent=2))


def _names(listed: str | None) -> tuple[str, ...] | None:
    """``"a,b"`` -> ``("a", "b")``; ``None`` stays ``None``."""
    return None if listed is None else tuple(name.strip() for name in listed.split(",") if name.strip())


def _train_with_progress(
    trainer: Any, skill: str, models: tuple[str, ...], data: Path, checkpoint: Path, overrides: dict[str, Any], sim: str, more_train: tuple[Path, ...],
    init_from: Path | None = None, anchor: tuple[Path, ...] = (), ood_exposure: tuple[Path, ...] = (),
) -> dict[str, Any]:
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

    console = Console(stderr=True)
    with Progress(
        TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(), TextColumn("{task.fields[metric]}"),
        TimeElapsedColumn(), TimeRemainingColumn(), console=console,
    ) as bar:
        tasks = {m: bar.add_task(f"{skill} {m}", total=None, metric="") for m in models}

        def update(model: str, step: int, total: int, record: dict[str, float]) -> None:
            shown = {k: v for k, v in record.items() if k in SHOWN_METRICS}
            bar.update(tasks[model], completed=step, total=total, metric=" ".join(f"{k} {v:.4g}" for k, v in shown.items()))

        # libraries without these keywords still train on one dataset from scratch
        extra: dict[str, Any] = {"more_train": more_train} if more_train else {}
        if init_from is not None:
            extra["init_from"] = init_from
        if anchor:
            extra["anchor"] = anchor
        if ood_exposure:
            extra["ood_exposure"] = ood_exposure
        result = trainer(skill, models, data, checkpoint, overrides, on_progress=update, simulator=sim, **extra)
    for model, outcome in result.items():
        console.print(f"{skill} {model}: best at step {outcome['best_step']}: {outcome['best']} ({outcome['steps_per_second'] or '-'} steps/s)")
    return result


def calibrate(
    skill: Annotated[str, typer.Option("--skill", help="pick, place, pull, push, or all.")],
    data: Annotated[Path, typer.Option("--data", help="Dataset directory with the validation and invalid splits.")],
    out: Annotated[Path, typer.Option("--out", help="Checkpoints directory (one sub-directory per skill).")],
    library: Annotated[str, typer.Option("--library", help="Skill library plugin.")] = "tableenv",
    as_json: Annotated[bool, typer.Option("--json", help="Print the thresholds as JSON on stdout.")] = False,
) -> None:
    """Calibrate the OOD thresholds of trained Q-ensembles on the validation and invalid splits, store
    them with the checkpoints and plot the variance histograms."""
    from rich.console import Console

    calibrator = library_entry(library, "calibrator")
    results = {}
    for name in _skills(skill):
        results[name] = result = calibrator(name, data, out / name)
        Console(stderr=True).print(
            f"{name}: threshold {result['threshold']:.4g}, detects {result['detection_rate']:.1%} of invalid pairs at "
            f"{result['false_positive_rate']:.2%} in-distribution false positives; planning rejects "
            f"{result['invalid_rejected_rate']:.1%} of invalid pairs (min Q < 0.5 or flagged)"
        )
    if as_json:
        typer.echo(json.dumps(results, indent=2))


def register(app: typer.Typer) -> None:
    """Add ``t2m train`` and ``t2m calibrate`` to the root app."""
    app.command("train")(train)
    app.command("calibrate")(calibrate)
