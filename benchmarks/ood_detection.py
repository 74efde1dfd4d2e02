"""How a skill library's OOD detector does on invalid pairs it was not calibrated or exposed on, and what
it costs on valid ones (docs/guide/skills.md#ood-exposure).

    python benchmarks/ood_detection.py --checkpoints DIR [--checkpoints DIR ...] --data DATA [--ood-detectors DIR | --published-ood] [--json OUT]

For every skill of every library, with the threshold stored in its checkpoint (with
``--ood-detectors``, the separate detectors' variance and thresholds; docs/guide/skills.md#a-separate-detector):

- detection: the share of ``DATA/<skill>/invalid`` pairs (uniform actions) the variance flags;
- detection with the policy's action: the same invalid states, each with the action the skill's
  policy proposes there (what a planner's first candidate for an invalid call looks like);
- rejected: the share planning rejects (min-of-8 Q below 0.5 or flagged), for both;
- false positives: the share of ``DATA/<skill>/validation`` pairs (valid calls) flagged;
- the validation BCE, precision and recall of the min-of-8 prediction.

Exits 1 when a directory lacks a skill's splits or checkpoint.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import torch

SKILLS = ("pick", "place", "pull", "push")


@torch.no_grad()
def measure(checkpoints: Path, data: Path, ood_detectors: Path | None = None, published_ood: bool = False) -> dict[str, dict[str, float]]:
    """skill -> the figures above, for the library in ``checkpoints`` (its detectors in ``ood_detectors``,
    else those it holds; its Q-ensembles with ``published_ood``)."""
    from dataclasses import replace

    from t2m_skills_tableenv.calibration import ensemble_statistics
    from t2m_skills_tableenv.dataset import SkillTensors
    from t2m_skills_tableenv.library import load_library
    from t2m_skills_tableenv.options import TableEnvSkillsOptions
    from t2m_skills_tableenv.training import q_metrics

    library = load_library(TableEnvSkillsOptions(checkpoints=checkpoints, ood_detectors=ood_detectors, published_ood=published_ood))
    results = {}
    for name in SKILLS:
        skill = library[name]
        detector = skill.ood_ensemble
        invalid = SkillTensors.load(data / name / "invalid")
        validation = SkillTensors.load(data / name / "validation")
        row = {"threshold": skill.ood_threshold}
        for label, pairs in (("uniform", invalid), ("policy", replace(invalid, actions=skill.policy(invalid.states())))):
            minimum = ensemble_statistics(skill.q_ensemble, pairs)[2]
            flagged = ensemble_statistics(detector, pairs)[1] >= skill.ood_threshold
            row[f"detection_{label}"] = float(flagged.mean())
            row[f"rejected_{label}"] = float(((minimum < 0.5) | flagged).mean())
        row["false_positives"] = float((ensemble_statistics(detector, validation)[1] >= skill.ood_threshold).mean())
        row.update({f"validation_{k}": v for k, v in q_metrics(skill.q_ensemble, validation).items()})
        row["invalid_pairs"], row["validation_pairs"] = len(invalid), len(validation)
        results[name] = row
    return results


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--checkpoints", type=Path, action="append", required=True, help="a skill library's checkpoints directory (repeatable)")
    parser.add_argument("--data", type=Path, required=True, help="dataset directory with each skill's validation and invalid splits")
    parser.add_argument("--ood-detectors", type=Path, help="separate detectors' checkpoints directory, for every library")
    parser.add_argument("--published-ood", action="store_true", help="each Q-ensemble's own variance, ignoring any detectors")
    parser.add_argument("--json", type=Path, help="write the figures here")
    args = parser.parse_args(argv)
    torch.set_num_threads(1)
    from t2m_core.errors import T2MError

    try:
        results = {str(directory): measure(directory, args.data, args.ood_detectors, args.published_ood) for directory in args.checkpoints}
    except (T2MError, OSError, ValueError) as error:  # a missing split or checkpoint: the library's own message
        print(f"error: {error}", file=sys.stderr)
        return 1
    header = "| library | skill | threshold | detection (uniform / policy actions) | rejected (uniform / policy) | false positives | validation BCE | precision / recall |"
    print(header)
    print("|---" * (header.count("|") - 1) + "|")
    for library, skills in results.items():
        for name, r in skills.items():
            print(f"| {library} | {name} | {r['threshold']:.3g} | {r['detection_uniform']:.1%} / {r['detection_policy']:.1%} "
                  f"| {r['rejected_uniform']:.2%} / {r['rejected_policy']:.2%} | {r['false_positives']:.2%} | {r['validation_loss']:.3f} "
                  f"| {r['validation_precision']:.1%} / {r['validation_recall']:.1%} |")
    if args.json:
        from t2m_core.atomic_files import write_json_atomic

        write_json_atomic(args.json, {"data": str(args.data), "libraries": results})
    return 0


if __name__ == "__main__":
    sys.exit(main())
