"""OOD calibration of a skill's Q-ensemble (docs/guide/skills.md#calibration).

For in-distribution pairs (the validation split: symbolically valid calls, successes and failures)
and invalid pairs (the invalid split: symbolically invalid calls, uniform actions), compute the
mean μ and the population variance σ² of the B member probabilities, bin σ² by μ (10 bins of width
0.1) and choose the smallest threshold ε at which at most 1 % of the in-distribution pairs of every
bin are flagged. The threshold, its detection and false-positive rates and a histogram plot are
stored with the checkpoint.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from t2m_skills_tableenv.checkpoints import load_q, update_config
from t2m_skills_tableenv.dataset import SkillTensors

MEAN_BINS = np.linspace(0.0, 1.0, 11)
"""Edges of the μ bins."""
FALSE_POSITIVE_BUDGET = 0.01
"""Largest share of in-distribution pairs flagged in any μ bin."""
MIN_BIN_COUNT = 20
"""Bins with fewer in-distribution pairs do not set the threshold (a 99th percentile of a handful
of samples is noise)."""
PLOT_NAME = "ood_calibration.png"


@torch.no_grad()
def ensemble_statistics(q_ensemble: nn.Module, data: SkillTensors, batch: int = 8192) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(mean (N,), population variance (N,), minimum (N,))`` of the member probabilities on every pair."""
    means, variances, minima = [], [], []
    for start in range(0, len(data), batch):
        index = slice(start, start + batch)
        probabilities = q_ensemble.probabilities(data.states(index), data.actions[index])
        means.append(probabilities.mean(dim=1))
        variances.append(probabilities.var(dim=1, unbiased=False))
        minima.append(probabilities.min(dim=1).values)
    return torch.cat(means).numpy(), torch.cat(variances).numpy(), torch.cat(minima).numpy()


def choose_threshold(mean: np.ndarray, variance: np.ndarray) -> float:
    """The smallest ε flagging at most 1 % of the in-distribution pairs in every populated μ bin."""
    bins = np.clip(np.digitize(mean, MEAN_BINS) - 1, 0, len(MEAN_BINS) - 2)
    threshold = 0.0
    for b in range(len(MEAN_BINS) - 1):
        in_bin = variance[bins == b]
        if len(in_bin) >= MIN_BIN_COUNT:
            # flagged: variance >= ε, so ε just above the (1 - budget) quantile
            threshold = max(threshold, float(np.nextafter(np.quantile(in_bin, 1.0 - FALSE_POSITIVE_BUDGET, method="higher"), np.inf)))
    return threshold


def per_bin_rates(mean: np.ndarray, variance: np.ndarray, threshold: float) -> list[dict[str, float]]:
    """Flagged share and count of the pairs in each μ bin."""
    bins = np.clip(np.digitize(mean, MEAN_BINS) - 1, 0, len(MEAN_BINS) - 2)
    rows = []
    for b in range(len(MEAN_BINS) - 1):
        in_bin = variance[bins == b]
        rows.append({"mean_low": round(float(MEAN_BINS[b]), 2), "count": int(len(in_bin)), "flagged": float((in_bin >= threshold).mean()) if len(in_bin) else 0.0})
    return rows


def calibrate_skill(skill: str, data: Path, checkpoint: Path) -> dict[str, Any]:
    """Calibrate ``checkpoint``'s Q-ensemble on ``data/<skill>/validation`` and
    ``data/<skill>/invalid``; store and return the result."""
    from t2m_core.data.generate import manifest_digest

    q_ensemble = load_q(Path(checkpoint)).eval()
    validation_dir, invalid_dir = Path(data) / skill / "validation", Path(data) / skill / "invalid"
    _refuse_exposed_pairs(Path(checkpoint), invalid_dir, manifest_digest(invalid_dir))
    valid_mean, valid_var, _ = ensemble_statistics(q_ensemble, SkillTensors.load(validation_dir))
    invalid_mean, invalid_var, invalid_min = ensemble_statistics(q_ensemble, SkillTensors.load(invalid_dir))
    threshold = choose_threshold(valid_mean, valid_var)
    result = {
        "threshold": threshold,
        "statistic": "population variance of the member probabilities; flagged when >= threshold",
        "rule": f"smallest threshold flagging <= {FALSE_POSITIVE_BUDGET:.0%} of in-distribution pairs in every mean bin",
        "detection_rate": float((invalid_var >= threshold).mean()),
        # the invalid pairs that would pass as feasible without the detector (mean Q >= 0.5): where it matters
        "detection_rate_where_q_high": float((invalid_var[invalid_mean >= 0.5] >= threshold).mean()) if (invalid_mean >= 0.5).any() else None,
        "invalid_share_with_q_high": float((invalid_mean >= 0.5).mean()),
        # what planning does with an invalid pair: rejected when the pessimistic Q (min of the
        # members) is below 0.5 or the detector flags it
        "invalid_rejected_rate": float(((invalid_min < 0.5) | (invalid_var >= threshold)).mean()),
        "false_positive_rate": float((valid_var >= threshold).mean()),
        "in_distribution_pairs": int(len(valid_var)),
        "invalid_pairs": int(len(invalid_var)),
        "median_variance": {"in_distribution": float(np.median(valid_var)), "invalid": float(np.median(invalid_var))},
        "bins": {"in_distribution": per_bin_rates(valid_mean, valid_var, threshold), "invalid": per_bin_rates(invalid_mean, invalid_var, threshold)},
        "data": {"validation": manifest_digest(validation_dir), "invalid": manifest_digest(invalid_dir)},
        "plot": PLOT_NAME,
    }
    plot_calibration(Path(checkpoint) / PLOT_NAME, skill, (valid_mean, valid_var), (invalid_mean, invalid_var), threshold)
    update_config(Path(checkpoint), ood=result)
    return result


def _refuse_exposed_pairs(checkpoint: Path, invalid_dir: Path, digest: str) -> None:
    """Detection measured on the invalid pairs the ensemble learnt to flag (OOD exposure) would
    overstate it.

    Raises:
        T2MError: ``invalid_dir`` is one of the Q-ensemble's exposure splits.
    """
    from t2m_core.errors import T2MError
    from t2m_skills_tableenv.checkpoints import read_config

    exposed = read_config(checkpoint).get("models", {}).get("q", {}).get("data", {}).get("ood_exposure", [])
    if digest in exposed:
        raise T2MError(
            f"{invalid_dir} is the invalid split {checkpoint}'s Q-ensemble was exposed to in training: its detection rate there says nothing",
            "calibrate on another invalid split (t2m datagen --split invalid with another --seed)",
        )


def plot_calibration(path: Path, skill: str, valid: tuple[np.ndarray, np.ndarray], invalid: tuple[np.ndarray, np.ndarray], threshold: float) -> None:
    """Histograms of the member variance per μ bin, in-distribution against invalid, with ε."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from t2m_core.atomic_files import write_bytes_atomic

    figure, axes = plt.subplots(2, 5, figsize=(15, 5.5), sharex=True)
    edges = np.logspace(-8, np.log10(0.25), 40)
    for b, axis in enumerate(axes.flat):
        low, high = MEAN_BINS[b], MEAN_BINS[b + 1]
        plotted = False
        for (mean, variance), label, colour in ((valid, "in distribution", "tab:blue"), (invalid, "invalid", "tab:red")):
            in_bin = variance[(mean >= low) & ((mean < high) | (b == 9))]
            if len(in_bin):
                axis.hist(np.clip(in_bin, edges[0], None), bins=edges, weights=np.full(len(in_bin), 1 / len(in_bin)), alpha=0.55, color=colour, label=f"{label} ({len(in_bin)})")
                plotted = True
        axis.axvline(threshold, color="black", linestyle="--", linewidth=1)
        axis.set_xscale("log")
        axis.set_title(f"mean Q in [{low:.1f}, {high:.1f})" + ("" if plotted else ": no pairs"), fontsize=9)
        if plotted:  # an empty bin has nothing to label (matplotlib warns)
            axis.legend(fontsize=7)
    figure.supxlabel("variance of the 8 member probabilities (log scale); dashed: threshold")
    figure.supylabel("share of the bin's pairs")
    figure.suptitle(f"{skill}: OOD calibration, threshold {threshold:.3g}")
    figure.tight_layout()
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=80)
    plt.close(figure)
    write_bytes_atomic(path, buffer.getvalue())
