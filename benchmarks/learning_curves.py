"""Learning curves: a skill's model quality against the size of its training set.

    python benchmarks/learning_curves.py --skill pick --sizes 1250,2500,5000,10000,20000
        --data datasets/tableenv --work /tmp/curves --json OUT [--models q,dynamics] [--steps 20000]
        [--plot PNG] [--validation-size N] [--measure-only]
    python benchmarks/learning_curves.py --combine A.json,B.json --plot PNG   (one plot of several skills)

Trains the models on the first N training transitions (``t2m train --train-size N``: exactly what
``t2m datagen --size N`` writes, since chunks are deterministic) for every N, with the same step
budget, into ``WORK/<skill>-<N>/`` (resumable: a killed run continues where it stopped; at the
split's full size it is ``t2m train``'s default run, so a finished ``t2m train`` checkpoint copied
there with its ``.training/`` states is reused), and
measures each on the full validation split: Q precision / recall / accuracy / loss of the
pessimistic prediction and what it gets wrong per outcome (each failure reason), the dynamics'
median position error of the moved object (mm). A curve that still rises at its largest size says
more data would help. Prints a table and writes JSON.

``--validation-size N`` measures on the first N validation transitions only (chunks are
deterministic, so a curve measured on a smaller split stays comparable); ``--measure-only`` measures
the checkpoints already in ``WORK/<skill>-<N>/`` (trained elsewhere, say) without training.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--skill")
    parser.add_argument("--sizes", help="comma-separated training-set sizes")
    parser.add_argument("--data", type=Path, default=Path("datasets/tableenv"))
    parser.add_argument("--work", type=Path, help="directory for the per-size checkpoints")
    parser.add_argument("--models", default="q,dynamics", help="q, dynamics (policy success needs simulation: see `t2m skills report`)")
    parser.add_argument("--steps", type=int, default=None, help="optimiser steps per model (default: the library's)")
    parser.add_argument("--json", dest="json_out", type=Path)
    parser.add_argument("--plot", type=Path, default=None)
    parser.add_argument("--validation-size", type=int, default=None, help="measure on the first N validation transitions")
    parser.add_argument("--measure-only", action="store_true", help="measure the checkpoints in WORK without training")
    parser.add_argument("--combine", help="comma-separated JSON files written by this script: plot them together (no training)")
    args = parser.parse_args()
    if args.combine:
        if not args.plot:
            parser.error("--combine needs --plot")
        plot_curves(args.plot, [json.loads(Path(name).read_text()) for name in args.combine.split(",")])
        return
    missing = [flag for flag, value in (("--skill", args.skill), ("--sizes", args.sizes), ("--work", args.work), ("--json", args.json_out)) if not value]
    if missing:
        parser.error(f"missing {', '.join(missing)}")

    import torch

    from t2m_core.atomic_files import write_json_atomic
    from t2m_core.data.generate import load_split
    from t2m_skills_tableenv.dataset import SkillTensors
    from t2m_skills_tableenv.checkpoints import load_dynamics, load_q
    from t2m_skills_tableenv.report import dynamics_errors, errors_by_outcome
    from t2m_skills_tableenv.training import q_metrics, train_skill

    models = tuple(args.models.split(","))
    unknown = set(models) - {"q", "dynamics"}
    if unknown:
        parser.error(f"unknown models {sorted(unknown)}: learning curves measure q and dynamics")
    transitions = load_split(args.data / args.skill / "validation")
    if args.validation_size is not None:
        if not 0 < args.validation_size <= len(transitions):
            parser.error(f"--validation-size must be in 1..{len(transitions)} (the validation split's size)")
        transitions = transitions.take(slice(0, args.validation_size))
    validation = SkillTensors.from_transitions(transitions)
    keep = transitions.success
    available = None if args.measure_only else json.loads((args.data / args.skill / "train" / "manifest.json").read_text())["count"]
    points = []
    for size in (int(s) for s in args.sizes.split(",")):
        checkpoint = args.work / f"{args.skill}-{size}"
        # the whole split is what `t2m train` uses by default: its checkpoint serves as this point
        overrides = {**({"train_size": size} if available and size < available else {}), **({"steps": args.steps} if args.steps else {})}
        started = time.perf_counter()
        if args.measure_only:
            results = _recorded_results(checkpoint, models)
            point: dict = {"train_size": size, "train_seconds": None}
        else:
            results = train_skill(args.skill, models, args.data, checkpoint, overrides)
            point = {"train_size": size, "train_seconds": round(time.perf_counter() - started, 1)}
        if "q" in models:
            ensemble = load_q(checkpoint).eval()
            point["q"] = q_metrics(ensemble, validation)
            point["q"]["best_step"] = results["q"]["best_step"]
            with torch.no_grad():
                q_min = ensemble.probabilities(validation.states(), validation.actions).min(dim=1).values.numpy()
            point["q"]["by_outcome"] = errors_by_outcome(q_min, transitions.failure_names())
        if "dynamics" in models:
            dynamics = load_dynamics(checkpoint).eval()
            point["dynamics"] = dynamics_errors(
                dynamics, validation.successes(), transitions.row_order[keep], transitions.shuffle_range[keep],
                transitions.observation[keep], transitions.next_observation[keep],
            )
        points.append(point)
        print(json.dumps(point), flush=True)
    report = {"skill": args.skill, "steps": args.steps, "validation_size": len(validation), "points": points}
    write_json_atomic(args.json_out, report)
    _print_table(report)
    if args.plot:
        plot_curves(args.plot, [report])


def _recorded_results(checkpoint: Path, models: tuple[str, ...]) -> dict:
    """The training results a finished checkpoint's ``config.json`` records, per model."""
    config_path = checkpoint / "config.json"
    if not config_path.exists():
        raise SystemExit(f"--measure-only: no checkpoint in {checkpoint} (train it first, or copy one there)")
    recorded = json.loads(config_path.read_text())["models"]
    missing = [model for model in models if model not in recorded]
    if missing:
        raise SystemExit(f"--measure-only: {config_path} has no {', '.join(missing)} model")
    return {model: recorded[model]["result"] for model in models}


def _print_table(report: dict) -> None:
    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"{report['skill']}: quality against training-set size (validation {report['validation_size']})")
    for column in ("train size", "Q precision", "Q recall", "Q accuracy", "Q loss", "moved mm (median)", "train s"):
        table.add_column(column, justify="right")
    for point in report["points"]:
        q, dynamics = point.get("q", {}), point.get("dynamics", {})
        table.add_row(
            str(point["train_size"]),
            *(f"{100 * q[k]:.1f} %" if k in q else "-" for k in ("precision", "recall", "accuracy")),
            f"{q['loss']:.3f}" if "loss" in q else "-",
            f"{dynamics['moved_mm_median']:.1f}" if "moved_mm_median" in dynamics else "-",
            f"{point['train_seconds']:.0f}" if point["train_seconds"] is not None else "-",
        )
    Console().print(table)


def plot_curves(path: Path, reports: list[dict]) -> None:
    """Q precision / recall, Q validation loss and (when measured) the dynamics error against
    training-set size, one line per skill."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with_dynamics = any("dynamics" in p for r in reports for p in r["points"])
    figure, axes = plt.subplots(1, 3 if with_dynamics else 2, figsize=(15 if with_dynamics else 10, 4))
    for report in reports:
        points = [p for p in report["points"] if "q" in p]
        sizes = [p["train_size"] for p in points]
        line = axes[0].plot(sizes, [100 * p["q"]["precision"] for p in points], "o-", label=f"{report['skill']} precision")[0]
        axes[0].plot(sizes, [100 * p["q"]["recall"] for p in points], "s--", color=line.get_color(), label=f"{report['skill']} recall")
        axes[1].plot(sizes, [p["q"]["loss"] for p in points], "o-", color=line.get_color(), label=report["skill"])
        if with_dynamics:
            measured = [p for p in report["points"] if "dynamics" in p]
            axes[2].plot([p["train_size"] for p in measured], [p["dynamics"]["moved_mm_median"] for p in measured], "o-", color=line.get_color(), label=report["skill"])
    axes[0].axhline(95, color="grey", linewidth=0.8, linestyle=":", label="floor 95 %")
    labels = ["Q-ensemble, min of 8 > 0.5 (%)", "Q-ensemble validation BCE"]
    if with_dynamics:
        axes[2].axhline(10, color="grey", linewidth=0.8, linestyle=":", label="floor 10 mm")
        labels.append("moved object, median error (mm)")
    ticks: list[int] = []
    for size in sorted({p["train_size"] for r in reports for p in r["points"]}, reverse=True):
        if not ticks or ticks[-1] / size >= 1.3:  # labels of sizes closer than that would overlap
            ticks.append(size)
    ticks.reverse()
    for axis, label in zip(axes, labels):
        axis.set_xscale("log")
        axis.set_xticks(ticks, [f"{size / 1000:g}k" for size in ticks])
        axis.minorticks_off()
        axis.set_xlabel("training transitions")
        axis.set_ylabel(label)
        axis.legend(fontsize=7)
        axis.grid(alpha=0.3)
    figure.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(path, dpi=120)


if __name__ == "__main__":
    main()
