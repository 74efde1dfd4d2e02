"""How well the learned values predicted what the simulator then did, read from run directories.

    python benchmarks/execution_values.py EVAL_OR_RUN_DIR [...] [--json OUT]

Every executed skill of a run record carries the min-of-8 value that its closed-loop re-plan gave it
just before it ran (``plan_tree.jsonl``, event ``executed``) and the simulator's outcome. Per skill,
over every executed step of the given directories (evaluation directories written by ``t2m eval`` or
single run directories): the steps, the failures and their reasons, the mean value of the steps that
succeeded and of those that failed, and the area under the ROC curve of the value against the outcome
(0.5: the value says nothing about which steps fail; 1: every failure was valued below every success).
Per episode: the accepted plan's ``p_success`` in bins against the fraction of those episodes that
reached the goal. An episode directory counts once even when two given directories hold it.

With ``--checkpoints DIR`` (repeatable), every episode is also replayed in its recorded simulator
(``replay.py``) and each executed step valued again, at the state it ran from, by the skill library
loaded from ``DIR``: would another set of checkpoints have told the failures from the successes
better? (The steps are the ones the recorded library chose; a library valued on them is judged
where that library's planner went, not where its own would go.) ``--geometric-prediction`` does the same
for the domain's geometric prediction of a Pick whose fingers land on another object or the table
(or whose object lies outside the workspace), of a Pull or Push that sweeps into another object and
of a Place that sets its object down against one (the planners' ``veto`` option): its value is 0 for
such a step, 1 otherwise.
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
from action_ranking import roc_auc
from replay import start_replay
from t2m_skills_tableenv.report import reliability

from t2m_core.atomic_files import write_json_atomic
from t2m_core.errors import T2MError
from t2m_core.run_records import read_plan_tree, read_result

P_SUCCESS_BINS = (0.0, 0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0)
"""Edges of the accepted plans' ``p_success`` bins (the last bin includes 1)."""
GEOMETRIC_PREDICTION = "geometric prediction"
"""The key of the geometric prediction's verdicts among the revalued steps."""
Step = tuple[float, bool, str | None]
"""One executed step: its value, whether it succeeded, the failure reason."""


def episode_directories(paths: list[Path]) -> list[Path]:
    """Run directories (holding ``result.json``) at or below ``paths``, each once, sorted."""
    found = set()
    for path in paths:
        found.update(result.parent.resolve() for result in path.glob("**/result.json"))  # ** matches path itself too
    return sorted(found)


def collect(directories: list[Path]) -> tuple[dict[str, list[Step]], list[tuple[float, bool]]]:
    """Per skill name: ``(value, succeeded, failure)`` of every executed step; per episode with an
    accepted plan: ``(p_success, reached the goal)``."""
    steps: dict[str, list[Step]] = {}
    episodes: list[tuple[float, bool]] = []
    for directory in directories:
        result = read_result(directory)
        if result is None:
            continue
        records = read_plan_tree(directory)
        for record in records:
            if record["event"] == "executed":
                skill = record["skill"].split("(", 1)[0]
                step = (float(record["value"]), bool(record["success"]), record.get("failure"))
                steps.setdefault(skill, []).append(step)
        plans = [r for r in records if r["event"] == "plan" and r.get("found")]
        if plans:
            episodes.append((float(plans[-1]["p_success"]), bool(result.get("success"))))
    return steps, episodes


def revalue(directories: list[Path], checkpoints: list[Path], geometric_prediction: bool = False) -> dict[str, dict[str, list[Step]]]:
    """Per checkpoints directory, per skill name: ``(value, succeeded, failure)`` of every executed
    step, its value the min-of-ensemble Q (clipped to [0, 1]) of the recorded run's skill library
    plugin loaded from that directory, at the replayed state the step ran from. With
    ``geometric_prediction``, also under the key :data:`GEOMETRIC_PREDICTION`, for the skills whose
    primitive has one (Pull, Push, Place): value 0 where the domain's geometry predicts the recorded
    action to drive something into another object (the primitive's ``in_the_way``, the planners'
    geometric veto), else 1.

    Raises:
        T2MError: a replay that does not reproduce its record, or a checkpoint that does not load.
    """
    from t2m_core.domain.observation import argument_first_order, skill_state
    from t2m_core.domain.primitives import get_primitive
    from t2m_core.registry import get_registry

    libraries: dict[tuple[str, Path], Any] = {}
    steps: dict[str, dict[str, list[Step]]] = {str(directory): {} for directory in checkpoints}
    if geometric_prediction:
        steps[GEOMETRIC_PREDICTION] = {}
    for run in directories:
        replay = start_replay(run)
        block = replay.config.skills
        for directory in checkpoints:
            if (block.name, directory) not in libraries:
                libraries[block.name, directory] = get_registry().create("skill_library", block.name, {**block.options, "checkpoints": str(directory)})
        for _index, call, record in replay.steps():
            observation = np.asarray(replay.simulator.observation(), dtype=np.float32)
            state = skill_state(observation, argument_first_order(replay.names, call.args)).astype(np.float32)[None]
            action = np.asarray(record["action"], dtype=np.float32)[None]
            for directory in checkpoints:
                members = np.asarray(libraries[block.name, directory][call.name].q_values(state, action))
                value = float(np.clip(members.min(), 0.0, 1.0))
                steps[str(directory)].setdefault(call.name, []).append((value, bool(record["success"]), record.get("failure")))
            primitive = get_primitive(call.name) if geometric_prediction else None
            if primitive is not None and hasattr(primitive, "in_the_way"):
                physical = primitive.to_physical(np.asarray(record["action"], dtype=np.float64))[None]
                blocked = bool(primitive.in_the_way(replay.simulator.geometric_state(), call.args, physical)[0])
                steps[GEOMETRIC_PREDICTION].setdefault(call.name, []).append((0.0 if blocked else 1.0, bool(record["success"]), record.get("failure")))
    return steps


def skill_table(steps: dict[str, list[Step]]) -> list[dict]:
    """One row per skill: counts, mean values by outcome, AUC, failure reasons."""
    rows = []
    for skill in sorted(steps):
        values = np.array([s[0] for s in steps[skill]])
        success = np.array([s[1] for s in steps[skill]])
        rows.append({
            "skill": skill,
            "steps": int(len(values)),
            "failures": int((~success).sum()),
            "mean_value_success": float(values[success].mean()) if success.any() else None,
            "mean_value_failure": float(values[~success].mean()) if (~success).any() else None,
            "auc": roc_auc(values, success),
            "failure_reasons": dict(Counter(s[2] for s in steps[skill] if not s[1]).most_common()),
        })
    return rows


def _fmt(value: float | None, form: str = ".2f") -> str:
    return "n/a" if value is None else format(value, form)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("directories", nargs="+", type=Path, help="evaluation or run directories")
    parser.add_argument("--checkpoints", action="append", type=Path, default=[],
                        help="also value every executed step again with the skill library loaded from this checkpoints directory (repeatable)")
    parser.add_argument("--geometric-prediction", action="store_true",
                        help="also judge every executed Pick, Pull, Push and Place by the domain's geometric prediction (0: into another object)")
    parser.add_argument("--json", dest="json_out", default=None)
    args = parser.parse_args()
    directories = episode_directories(args.directories)
    if not directories:
        sys.exit(f"no run directory (with a result.json) at or below {', '.join(map(str, args.directories))}: "
                 "give directories written by `t2m run` or `t2m eval`")
    try:
        steps, episodes = collect(directories)
        revalued = revalue(directories, args.checkpoints, args.geometric_prediction) if args.checkpoints or args.geometric_prediction else {}
    except T2MError as error:
        sys.exit(f"{error.message}: {error.hint}" if error.hint else error.message)
    predicted = np.array([e[0] for e in episodes])
    reached = np.array([e[1] for e in episodes], dtype=bool)
    skills, bins = skill_table(steps), reliability(predicted, reached, P_SUCCESS_BINS)
    print(f"{len(directories)} episodes, {sum(len(v) for v in steps.values())} executed steps")
    print(f"{'skill':6s} {'steps':>6s} {'failed':>6s} {'value ok':>9s} {'value fail':>10s} {'AUC':>6s}  failures")
    for row in skills:
        print(f"{row['skill']:6s} {row['steps']:6d} {row['failures']:6d} {_fmt(row['mean_value_success']):>9s} "
              f"{_fmt(row['mean_value_failure']):>10s} {_fmt(row['auc'], '.3f'):>6s}  {row['failure_reasons']}")
    for directory, by_skill in revalued.items():
        print(f"\nvalued again with {directory}:" if directory != GEOMETRIC_PREDICTION else "\njudged by the geometric prediction (0: into another object, 1: clear):")
        for row in skill_table(by_skill):
            print(f"{row['skill']:6s} {row['steps']:6d} {row['failures']:6d} {_fmt(row['mean_value_success']):>9s} "
                  f"{_fmt(row['mean_value_failure']):>10s} {_fmt(row['auc'], '.3f'):>6s}")
    print(f"\n{'accepted p_success':>20s} {'episodes':>9s} {'mean':>6s} {'reached':>8s}")
    for row in bins:
        print(f"{'from ' + str(row['bin_low']):>20s} {row['count']:9d} {row['predicted']:6.2f} {row['realised']:8.0%}")
    if args.json_out:
        report = {"directories": [str(p) for p in args.directories], "episodes": len(directories), "skills": skills,
                  "p_success_reliability": bins,
                  "revalued": {directory: skill_table(by_skill) for directory, by_skill in revalued.items()}}
        write_json_atomic(args.json_out, report)


if __name__ == "__main__":
    main()
