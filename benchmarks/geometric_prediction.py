"""How well the domain's geometric prediction of a skill's failures tells a dataset's failures from its
successes, beside the learned Q-ensemble's value on the same transitions.

    python benchmarks/geometric_prediction.py DATASET --skill pick [--split validation] [--checkpoints DIR] [--json OUT]

The prediction is the primitive's ``in_the_way`` (the planners' ``veto`` option,
docs/guide/feasibility.md#geometric-veto), read on each transition's decoded observation and action:
a Pick whose fingers land on the rack's plate, a neighbour or the table, or whose object lies
outside the workspace; a Pull or Push sweeping into another object; a Place setting its object
down against one. Per failure reason (and for the successes): the transitions and how many the
prediction flags. Then the area under the ROC curve against success of the prediction (0 where it
fires, 1 elsewhere), of the ensemble's min-of-8 value, and of that value vetoed by the prediction
(0 where it fires: what a planner with the ``veto`` option reads), over every transition and over
the failure reasons the prediction is about; and all of it per lifted call (the arguments' object
kinds: ``place(hook, table)``, ``place(box, rack)``, ...). ``DATASET`` is a directory written by
``t2m datagen`` (``DATASET/<skill>/<split>``); data sampled in the task scenes (``--scenes tasks``)
shows the situations the planners meet.
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path

import numpy as np
import torch
from action_ranking import roc_auc
from t2m_skills_tableenv.dataset import SkillTensors
from t2m_skills_tableenv.library import load_library
from t2m_skills_tableenv.options import TableEnvSkillsOptions

from t2m_core.atomic_files import write_json_atomic
from t2m_core.data.generate import load_split
from t2m_core.data.records import Transitions
from t2m_core.domain.observation import decode_observation
from t2m_core.domain.primitives import get_primitive
from t2m_core.domain.skills import SkillCall
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


def call_kinds(skill: str, transitions: Transitions) -> np.ndarray:
    """``(N,) str``: each transition's lifted call, its arguments' object kinds (``"place(hook, table)"``)."""
    return np.array([SkillCall(skill, transitions.argument_names(row)).lifted for row in range(len(transitions))])


def measure(skill: str, transitions: Transitions, values: np.ndarray) -> dict:
    """The table by outcome and the AUCs of the prediction and of ``values`` (N,) against success,
    over every transition and per kind of call (:func:`call_kinds`)."""
    flagged = predictions(skill, transitions)
    outcomes = np.array([failure or "success" for failure in transitions.failure_names()])
    kinds = call_kinds(skill, transitions)
    report = _measure(skill, flagged, outcomes, transitions.success, values)
    by_call = {kind: _measure(skill, flagged[kinds == kind], outcomes[kinds == kind], transitions.success[kinds == kind],
                              values[kinds == kind]) for kind in sorted(set(kinds.tolist()))}
    return {"skill": skill, "transitions": len(transitions), **report, "by_call": by_call}


def _measure(skill: str, flagged: np.ndarray, outcomes: np.ndarray, success: np.ndarray, values: np.ndarray) -> dict:
    by_outcome = {
        outcome: {"transitions": int(count), "flagged": int(flagged[outcomes == outcome].sum()),
                  "mean_value": float(values[outcomes == outcome].mean())}
        for outcome, count in Counter(outcomes.tolist()).most_common()
    }
    about = success | np.isin(outcomes, PREDICTED_REASONS[skill])
    return {
        "transitions": len(outcomes),
        "by_outcome": by_outcome,
        "auc_all": _aucs(flagged, values, success),
        "auc_predicted_reasons": {"reasons": list(PREDICTED_REASONS[skill]), **_aucs(flagged[about], values[about], success[about])},
    }


def _aucs(flagged: np.ndarray, values: np.ndarray, success: np.ndarray) -> dict:
    """AUCs against success of the prediction alone, the ensemble alone and the ensemble vetoed by
    the prediction (its value set to 0 where the prediction fires: what a planner with the veto reads)."""
    return {
        "prediction": roc_auc((~flagged).astype(float), success),
        "ensemble": roc_auc(values, success),
        "vetoed_ensemble": roc_auc(np.where(flagged, 0.0, values), success),
    }


def min_of_8(skill: str, transitions: Transitions, checkpoints: Path | None = None) -> np.ndarray:
    """``(N,)`` the min-of-8 value of each transition by ``skill``'s Q-ensemble in the library at
    ``checkpoints`` (default: the shipped one).

    Raises:
        T2MError: a missing or broken checkpoint.
    """
    options = TableEnvSkillsOptions() if checkpoints is None else TableEnvSkillsOptions(checkpoints=Path(checkpoints))
    tensors = SkillTensors.from_transitions(transitions)
    with torch.no_grad():
        return load_library(options)[skill].q_values(tensors.states(), tensors.actions).min(dim=1).values.numpy()


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
        values = min_of_8(args.skill, transitions, args.checkpoints)
    except T2MError as error:
        sys.exit(f"{error.message}: {error.hint}" if error.hint else error.message)
    report = measure(args.skill, transitions, values)
    _print(f"{args.skill}: {report['transitions']} transitions of {args.dataset / args.skill / args.split}", args.skill, report)
    for kind, part in report["by_call"].items():
        _print(f"\n{kind}: {part['transitions']} transitions", args.skill, part)
    if args.json_out:
        write_json_atomic(args.json_out, {"dataset": str(args.dataset), "split": args.split,
                                          "checkpoints": str(args.checkpoints or "shipped"), **report})


def _print(title: str, skill: str, report: dict) -> None:
    print(title)
    print(f"{'outcome':>20s} {'transitions':>12s} {'flagged':>8s} {'ensemble value':>15s}")
    for outcome, row in report["by_outcome"].items():
        print(f"{outcome:>20s} {row['transitions']:12d} {row['flagged']:8d} {row['mean_value']:15.2f}")
    for key, title in (("auc_all", "every transition"), ("auc_predicted_reasons", "successes and " + ", ".join(PREDICTED_REASONS[skill]))):
        auc = report[key]
        print(f"AUC on {title}: prediction {_fmt(auc['prediction'])}, ensemble {_fmt(auc['ensemble'])}, "
              f"vetoed ensemble {_fmt(auc['vetoed_ensemble'])}")


def _fmt(value: float | None) -> str:
    return "n/a" if value is None else f"{value:.3f}"


if __name__ == "__main__":
    main()
