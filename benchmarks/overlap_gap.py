"""Where an action meets a bystander: the screen's signed gap against each transition's outcome,
and what a skill's Q-ensembles call those transitions. Place's ``footprint_gap`` (the gap from the
set-down footprint to the nearest bystander part that rises above the held object's lowest point at
the release), Pull's and Push's ``sweep_gap`` (from the swept hook and box to the nearest part of a
bystander at the sweep's height); negative: how deep they reach into one.

    python benchmarks/overlap_gap.py DATASET [--skill place] [--split validation] [--checkpoints DIR,DIR] [--json OUT]

Per bin of the gap (millimetres): the transitions, successes, collisions, disturbances and other
failures; for each library in ``--checkpoints`` (``shipped`` for the packaged one), the successes
its min-of-8 value calls failures (≤ 0.5) and the failures it calls successes. Also how many
transitions the screen's ``clearance`` reads at the tools' floor (−1 cm: any overlap) and how many
of those succeed. Contact checks run every 10 ticks, so a set-down or a sweep that brushes a light
bystander a few millimetres deep can push it aside (by less than a disturbance) unseen.
``DATASET`` is a directory written by ``t2m datagen`` (``DATASET/<skill>/<split>``).
"""

from __future__ import annotations

import argparse
import itertools
import sys
from pathlib import Path

import numpy as np
from geometric_prediction import min_of_8
from support_margin import screen_margins

from t2m_core.atomic_files import write_json_atomic
from t2m_core.data.generate import load_split
from t2m_core.errors import T2MError

EDGES_MM = (-np.inf, -10.0, -5.0, -2.0, 0.0, 2.0, 5.0, 10.0, np.inf)
"""Bin edges of the gap, millimetres."""
GAPS = {"place": "footprint_gap", "pull": "sweep_gap", "push": "sweep_gap"}
"""The signed gap each skill's screen predicts."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("dataset", type=Path)
    parser.add_argument("--skill", choices=tuple(GAPS), default="place")
    parser.add_argument("--split", default="validation")
    parser.add_argument("--checkpoints", default="", help="comma-separated libraries (shipped: the packaged one)")
    parser.add_argument("--json", dest="json_out", default=None)
    args = parser.parse_args()
    try:
        transitions = load_split(args.dataset / args.skill / args.split)
        libraries = {name: min_of_8(args.skill, transitions, None if name == "shipped" else Path(name)) for name in filter(None, args.checkpoints.split(","))}
    except T2MError as error:
        sys.exit(f"error: {error}")
    measured = screen_margins(args.skill, transitions, (GAPS[args.skill], "clearance"))
    gap_mm, success = measured[GAPS[args.skill]] * 1000.0, transitions.success.astype(bool)
    failures = np.array(transitions.failure_names())
    collision, disturbed = failures == "collision", failures == "disturbed"
    floor = np.abs(measured["clearance"] + 0.01) < 1e-12
    report: dict = {
        "dataset": str(args.dataset), "skill": args.skill, "gap": GAPS[args.skill], "split": args.split, "transitions": len(transitions), "successes": int(success.sum()),
        "clearance_at_floor": {"transitions": int(floor.sum()), "successes": int((floor & success).sum())}, "bins": [],
    }
    print(f"{len(transitions)} transitions, {int(success.sum())} successes; clearance at its floor (−1 cm) in "
          f"{int(floor.sum())}, {int((floor & success).sum())} of them successes")
    header = "".join(f" | {name[-24:]:>24s} missed / false" for name in libraries)
    print(f"{GAPS[args.skill] + ' (mm)':>20s} {'n':>5s} {'succ':>5s} {'coll':>5s} {'dist':>5s} {'other':>5s}{header}")
    for low, high in itertools.pairwise(EDGES_MM):
        inside = (gap_mm >= low) & (gap_mm < high)
        row = {"low_mm": float(low), "high_mm": float(high), "transitions": int(inside.sum()), "successes": int((inside & success).sum()),
               "collisions": int((inside & collision).sum()), "disturbed": int((inside & disturbed).sum()), "libraries": {}}
        other = row["transitions"] - row["successes"] - row["collisions"] - row["disturbed"]
        line = f"{f'[{low:+.0f}, {high:+.0f})':>20s} {row['transitions']:5d} {row['successes']:5d} {row['collisions']:5d} {row['disturbed']:5d} {other:5d}"
        for name, values in libraries.items():
            missed, false = int((inside & success & (values <= 0.5)).sum()), int((inside & ~success & (values > 0.5)).sum())
            row["libraries"][name] = {"successes_called_failures": missed, "failures_called_successes": false}
            line += f" | {'':>24s} {missed:6d} / {false:5d}"
        report["bins"].append(row)
        print(line)
    for name, values in libraries.items():
        called = values > 0.5
        report.setdefault("totals", {})[name] = {
            "successes_called_failures": int((success & ~called).sum()), "failures_called_successes": int((~success & called).sum()),
            "precision": float((success & called).sum() / max(called.sum(), 1)), "recall": float((success & called).sum() / max(success.sum(), 1)),
        }
        print(f"{name}: precision {report['totals'][name]['precision']:.4f}, recall {report['totals'][name]['recall']:.4f}")
    if args.json_out:
        write_json_atomic(args.json_out, report)


if __name__ == "__main__":
    main()
