"""The skill library's quality report (``t2m skills report``, docs/guide/skills.md#quality-report).

Per skill: Q-ensemble precision, recall and accuracy of the pessimistic prediction on validation
data with a reliability curve and its errors by outcome (each failure reason); policy success in
simulated evaluation scenes; dynamics error of the moved object and of the others (position in mm,
yaw in degrees) on validation successes; the OOD detection and false-positive rates stored by
calibration; the dataset sizes.
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch

from t2m_core.atomic_files import write_bytes_atomic, write_json_atomic, write_text_atomic
from t2m_core.data.scenes import DATA_SKILLS
from t2m_core.domain.geometry import axis_angle_to_quat, quat_yaw, wrap_angle
from t2m_core.domain.observation import RowOrder, decode_dynamics_prediction
from t2m_skills_tableenv.dataset import SkillTensors
from t2m_skills_tableenv.episodes import REPORT_SEED, policy_success
from t2m_skills_tableenv.library import load_library
from t2m_skills_tableenv.networks import DynamicsModel
from t2m_skills_tableenv.options import TableEnvSkillsOptions
from t2m_skills_tableenv.training import q_metrics

RELIABILITY_BINS = np.linspace(0.0, 1.0, 11)


def reliability(predicted: np.ndarray, success: np.ndarray, edges: Sequence[float] = RELIABILITY_BINS) -> list[dict[str, float]]:
    """Per bin of predicted probability (``edges``; the last bin includes its upper edge): count,
    mean prediction, realised success rate. Empty bins are left out."""
    edges = np.asarray(edges, dtype=np.float64)
    bins = np.clip(np.digitize(predicted, edges) - 1, 0, len(edges) - 2)
    rows = []
    for b in range(len(edges) - 1):
        mask = bins == b
        if mask.any():
            rows.append({"bin_low": round(float(edges[b]), 2), "count": int(mask.sum()), "predicted": float(predicted[mask].mean()), "realised": float(success[mask].mean())})
    return rows


def errors_by_outcome(q_min: np.ndarray, failures: Sequence[str | None]) -> dict[str, dict[str, float]]:
    """How the pessimistic prediction (min of 8 > 0.5) fares on each outcome of the validation
    transitions: per failure reason (and ``"success"``), the count, the mean min-of-8 Q and the
    fraction it gets wrong (a failure called a success, or a success called a failure). A reason
    with a high wrong fraction is one the ensemble cannot see. Most frequent outcome first.

    Args:
        q_min: ``(N,)`` min-of-8 success probabilities.
        failures: ``N`` failure reasons, ``None`` for successes.
    """
    outcomes = np.array(["success" if reason is None else reason for reason in failures], dtype=object)
    called_success = np.asarray(q_min) > 0.5
    rows: dict[str, dict[str, float]] = {}
    names, counts = np.unique(outcomes, return_counts=True)
    for name, count in sorted(zip(names.tolist(), counts.tolist()), key=lambda item: (-item[1], item[0])):
        mask = outcomes == name
        wrong = ~called_success[mask] if name == "success" else called_success[mask]
        rows[name] = {"count": int(count), "mean_q_min": float(np.mean(q_min[mask])), "wrong": float(wrong.mean())}
    return rows


@torch.no_grad()
def dynamics_errors(dynamics: DynamicsModel, data: SkillTensors, row_orders: np.ndarray, shuffle_ranges: np.ndarray, observations: np.ndarray, next_observations: np.ndarray) -> dict[str, float]:
    """Median and 90th-percentile position (mm) and yaw (degrees) errors of the decoded dynamics
    prediction against the true next observation, for the moved object (the first argument) and
    for the other present objects."""
    predicted = dynamics(data.states(), data.actions).numpy()
    errors: dict[str, list[float]] = {"moved_mm": [], "moved_deg": [], "others_mm": [], "others_deg": []}
    for i in range(len(predicted)):
        order = row_orders[i].astype(np.int64)
        row_order = RowOrder(order, int(shuffle_ranges[i, 0]), int(shuffle_ranges[i, 1]))
        present = row_order.num_present
        decoded = decode_dynamics_prediction(predicted[i], observations[i], row_order)
        truth = next_observations[i]
        moved = int(order[1])
        for row in range(1, 1 + present):
            if not truth[row].any():
                continue  # the table: a constant row
            key = "moved" if row == moved else "others"
            errors[f"{key}_mm"].append(1000.0 * float(np.linalg.norm(decoded[row, :3] - truth[row, :3])))
            yaw_error = wrap_angle(quat_yaw(axis_angle_to_quat(decoded[row, 3:6])) - quat_yaw(axis_angle_to_quat(truth[row, 3:6])))
            errors[f"{key}_deg"].append(abs(float(np.degrees(yaw_error))))
    summary = {}
    for key, values in errors.items():
        if values:
            summary[f"{key}_median"] = float(np.median(values))
            summary[f"{key}_p90"] = float(np.percentile(values, 90))
    return summary


def report_library(
    checkpoints: Path, data: Path | None, episodes: int, out: Path, simulator: Any | None, ood_detectors: Path | None = None,
    published_ood: bool = False,
) -> dict[str, Any]:
    """Measure every skill of the library in ``checkpoints`` (with the separate OOD detectors in
    ``ood_detectors``, else those the directory holds, unless ``published_ood``); write
    ``report.json``, ``report.md`` and ``reliability.png`` into ``out``; return the report."""
    from t2m_core.data.generate import MANIFEST_NAME, load_split

    report: dict[str, Any] = {}
    library = load_library(TableEnvSkillsOptions(checkpoints=Path(checkpoints), ood_detectors=ood_detectors, published_ood=published_ood))
    for name in DATA_SKILLS:
        skill = library[name]
        entry: dict[str, Any] = {"ood": {k: skill.ood_calibration.get(k) for k in ("threshold", "detection_rate", "false_positive_rate", "invalid_rejected_rate")}}
        entry["ood"]["detector"] = None if skill.detector_directory is None else str(skill.detector_directory)
        if data is not None and (Path(data) / name / "validation" / MANIFEST_NAME).exists():
            import json

            entry["dataset"] = {
                split: json.loads((Path(data) / name / split / MANIFEST_NAME).read_text())["count"]
                for split in ("train", "validation", "invalid")
                if (Path(data) / name / split / MANIFEST_NAME).exists()
            }
            trained_on = skill.config.get("models", {}).get("q", {}).get("data", {}).get("train_transitions")
            if trained_on is not None:  # the checkpoint's own record beats the dataset's current size
                entry["dataset"]["train"] = trained_on
            transitions = load_split(Path(data) / name / "validation")
            validation = SkillTensors.from_transitions(transitions)
            entry["q"] = q_metrics(skill.q_ensemble, validation)
            q_min = skill.q_values(validation.states(), validation.actions).min(dim=1).values.numpy()
            entry["reliability"] = reliability(q_min, transitions.success)
            entry["q_by_outcome"] = errors_by_outcome(q_min, transitions.failure_names())
            keep = transitions.success
            entry["dynamics"] = dynamics_errors(
                skill.dynamics, validation.successes(), transitions.row_order[keep], transitions.shuffle_range[keep], transitions.observation[keep], transitions.next_observation[keep]
            )
        if simulator is not None and episodes > 0:
            entry["policy"] = policy_success(skill.name, skill.policy, simulator, episodes, seed=REPORT_SEED)
        report[name] = entry
    out.mkdir(parents=True, exist_ok=True)
    write_json_atomic(out / "report.json", report)
    write_text_atomic(out / "report.md", markdown_table(report))
    if any(entry.get("reliability") for entry in report.values()):
        plot_reliability(out / "reliability.png", report)
    return report


def markdown_table(report: dict[str, Any]) -> str:
    """The report as one markdown table, a row per skill."""
    lines = [
        "| skill | train / validation / invalid | Q precision | Q recall | Q accuracy | policy success | dynamics moved object, median mm / deg | others, median mm | OOD detection | OOD false positives | invalid pairs rejected |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]

    def percent(value: Any) -> str:
        return f"{value:.1%}" if isinstance(value, float) else "-"

    for name, entry in report.items():
        sizes = entry.get("dataset", {})
        q, dynamics, ood = entry.get("q", {}), entry.get("dynamics", {}), entry.get("ood", {})
        policy = entry.get("policy")
        lines.append(
            f"| {name} | {sizes.get('train', '-')} / {sizes.get('validation', '-')} / {sizes.get('invalid', '-')} "
            f"| {percent(q.get('precision'))} | {percent(q.get('recall'))} | {percent(q.get('accuracy'))} "
            f"| {percent(policy['success_rate']) + ' of ' + str(policy['episodes']) if policy else '-'} "
            f"| {dynamics.get('moved_mm_median', float('nan')):.1f} / {dynamics.get('moved_deg_median', float('nan')):.1f} "
            f"| {dynamics.get('others_mm_median', float('nan')):.1f} | {percent(ood.get('detection_rate'))} | {percent(ood.get('false_positive_rate'))} "
            f"| {percent(ood.get('invalid_rejected_rate'))} |"
        )
    outcome_rows = [
        f"| {name} | {outcome} | {row['count']} | {row['mean_q_min']:.2f} | {row['wrong']:.1%} |"
        for name, entry in report.items()
        for outcome, row in entry.get("q_by_outcome", {}).items()
    ]
    if outcome_rows:
        lines += [
            "",
            "Q-ensemble errors by outcome (validation): a failure called a success, or a success called a failure.",
            "",
            "| skill | outcome | transitions | mean min-of-8 Q | predicted wrongly |",
            "|---|---|---|---|---|",
            *outcome_rows,
        ]
    return "\n".join(lines) + "\n"


def plot_reliability(path: Path, report: dict[str, Any]) -> None:
    """Realised success against the predicted min-of-8 Q, one line per skill."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axis = plt.subplots(figsize=(5, 5))
    axis.plot([0, 1], [0, 1], color="grey", linestyle="--", linewidth=1, label="perfect calibration")
    for name, entry in report.items():
        rows = entry.get("reliability", [])
        if rows:
            axis.plot([r["predicted"] for r in rows], [r["realised"] for r in rows], marker="o", label=name)
    axis.set_xlabel("predicted success (min of 8 Q members)")
    axis.set_ylabel("realised success (validation)")
    axis.set_title("Q-ensemble reliability")
    axis.legend()
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=90, bbox_inches="tight")
    plt.close(figure)
    write_bytes_atomic(path, buffer.getvalue())
