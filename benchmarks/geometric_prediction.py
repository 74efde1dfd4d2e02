"""How well the domain's geometric prediction of a skill's failures tells a dataset's failures from its
successes, beside the learned Q-ensemble's value on the same transitions.

    python benchmarks/geometric_prediction.py DATASET --skill pick [--split validation] [--checkpoints DIR] [--json OUT]

The prediction is the primitive's ``in_the_way`` (the planners' ``veto`` option,
docs/guide/feasibility.md#geometric-veto), read on each transition's decoded observation and action:
a Pick whose fingers land on the rack's plate, a neighbour or the table, or whose object lies
outside the workspace; a Pull or Push sweeping into another object; a Place setting its object down
against one. Per failure reason (and for the successes): the transitions and how many the prediction
flags. Then the area under the ROC curve of the prediction (0 where it fires, 1 elsewhere) and of the
ensemble's min-of-8 value against success, over every transition and over the failure reasons the
prediction is about. ``DATASET`` is a directory written by ``t2m datagen`` (``DATASET/<skill>/<split>``);
data sampled in the task scenes (``--scenes tasks``) shows the situations the planners meet.
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path

import numpy as np
from action_ranking import roc_auc
from t2m_skills_tableenv.dataset import SkillTensors
from t2m_skills_tableenv.library import load_library
from t2m_skills_tableenv.options import TableEnvSkillsOptions

from t2m_core.atomic_files import write_json_atomic
from t2m_core.data.generate import load_split
from t2m_core.data.records import Transitions
from t2m_core.domain.observation import decode_observation
from t2m_core.domain.primitives import get_primitive
from t2m_core.errors import T2MError

PREDICTED_REASONS = {
    "pick": ("collision", "not_in_workspace"),
    "pull": ("disturbed",),
    "push": ("disturbed",),
    "place": ("collision", "disturbed"),
}
"""The failure reasons each skill's prediction is about."""


def predictions(skill: str, transitions: Transitions) -> np.ndarray:
    """``(N,) bool``: whether the prediction flags each transition (decoded observation, its action)."""
    primitive = get_primitive(skill)
    physical = primitive.to_physical(np.asarray(transitions.action, dtype=np.float64))
    flagged = np.zeros(len(transitions), dtype=bool)
    for row in range(len(transitions)):
        state = decode_observation(transitions.observation[row], transitions.object_names(row))
        flagged[row] = bool(primitive.in_the_way(state, transitions.argument_names(row), physical[row][None])[0])
    return flagged


def measure(skill: str, transitions: Transitions, values: np.ndarray) -> dict:
    """The table by outcome and the AUCs of the prediction and of ``values`` (N,) against success."""
    flagged = predictions(skill, transitions)
    outcomes = np.array([failure or "success" for failure in transitions.failure_names()])
    success = transitions.success
    by_outcome = {
        outcome: {"transitions": int(count), "flagged": int(flagged[outcomes == outcome].sum()),
                  "mean_value": float(values[outcomes == outcome].mean())}
        for outcome, count in Counter(outcomes.tolist()).most_common()
    }
    about = success | np.isin(outcomes, PREDICTED_REASONS[skill])
    return {
        "skill": skill,
        "transitions": len(transitions),
        "by_outcome": by_outcome,
        "auc_all": {"prediction": roc_auc((~flagged).astype(float), success), "ensemble": roc_auc(values, success)},
        "auc_predicted_reasons": {
            "reasons": list(PREDICTED_REASONS[skill]),
            "prediction": roc_auc((~flagged[about]).astype(float), success[about]),
            "ensemble": roc_auc(values[about], success[about]),
        },
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("dataset", type=Path, help="dataset directory written by `t2m datagen`")
    parser.add_argument("--skill", required=True, choices=sorted(PREDICTED_REASONS))
    parser.add_argument("--split", default="validation")
    parser.add_argument("--checkpoints", type=Path, default=None, help="skill library checkpoints (default: the shipped ones)")
    parser.add_argument("--json", dest="json_out", default=None)
    args = parser.parse_args()
    try:
        transitions = load_split(args.dataset / args.skill / args.split)
        options = TableEnvSkillsOptions() if args.checkpoints is None else TableEnvSkillsOptions(checkpoints=args.checkpoints)
        skill = load_library(options)[args.skill]
    except T2MError as error:
        sys.exit(f"{error.message}: {error.hint}" if error.hint else error.message)
    tensors = SkillTensors.from_transitions(transitions)
    values = skill.q_values(tensors.states(), tensors.actions).min(dim=1).values.numpy()
    report = measure(args.skill, transitions, values)
    print(f"{args.skill}: {report['transitions']} transitions of {args.dataset / args.skill / args.split}")
    print(f"{'outcome':>20s} {'transitions':>12s} {'flagged':>8s} {'ensemble value':>15s}")
    for outcome, row in report["by_outcome"].items():
        print(f"{outcome:>20s} {row['transitions']:12d} {row['flagged']:8d} {row['mean_value']:15.2f}")
    for key, title in (("auc_all", "every transition"), ("auc_predicted_reasons", "successes and " + ", ".join(PREDICTED_REASONS[args.skill]))):
        auc = report[key]
        print(f"AUC on {title}: prediction {_fmt(auc['prediction'])}, ensemble {_fmt(auc['ensemble'])}")
    if args.json_out:
        write_json_atomic(args.json_out, {"dataset": str(args.dataset), "split": args.split,
                                          "checkpoints": str(args.checkpoints or "shipped"), **report})


def _fmt(value: float | None) -> str:
    return "n/a" if value is None else f"{value:.3f}"


if __name__ == "__main__":
    main()
