"""Where a placement's footprint meets a bystander: Place's ``footprint_gap`` (signed: the gap to the
nearest bystander part that rises above the held object's lowest point at the release, minus how
deep the footprint reaches into one) against each transition's outcome, and what Place's
Q-ensembles call those transitions.

    python benchmarks/place_overlap.py DATASET [--split validation] [--checkpoints DIR,DIR] [--json OUT]

Per bin of the gap (millimetres; negative: overlapping): the transitions, successes, collisions
and other failures; for each library in ``--checkpoints`` (``shipped`` for the packaged one), the
successes its min-of-8 value calls failures (≤ 0.5) and the failures it calls successes. Also how
many transitions the screen's ``clearance`` reads at its floor (−1 cm: any overlap) and how many of
those succeed. The descent's contact checks run every 10 ticks, so a set-down that brushes a light
bystander a few millimetres deep can push it aside (by less than a disturbance) unseen.
``DATASET`` is a directory written by ``t2m datagen`` (``DATASET/place/<split>``).
"""

from __future__ import annotations

import argparse
import itertools
import sys
from pathlib import Path

import numpy as np
from geometric_prediction import min_of_8
from support_margin import place_margins

from t2m_core.atomic_files import write_json_atomic
from t2m_core.data.generate import load_split
from t2m_core.errors import T2MError

EDGES_MM = (-np.inf, -10.0, -5.0, -2.0, 0.0, 2.0, 5.0, 10.0, np.inf)
"""Bin edges of the footprint gap, millimetres."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("dataset", type=Path)
    parser.add_argument("--split", default="validation")
    parser.add_argument("--checkpoints", default="", help="comma-separated libraries (shipped: the packaged one)")
    parser.add_argument("--json", dest="json_out", default=None)
    args = parser.parse_args()
    try:
        transitions = load_split(args.dataset / "place" / args.split)
        libraries = {name: min_of_8("place", transitions, None if name == "shipped" else Path(name)) for name in filter(None, args.checkpoints.split(","))}
    except T2MError as error:
        sys.exit(f"error: {error}")
    measured = place_margins(transitions, ("footprint_gap", "clearance"))
    gap_mm, success = measured["footprint_gap"] * 1000.0, transitions.success.astype(bool)
    collision = np.array([failure == "collision" for failure in transitions.failure_names()])
    floor = measured["clearance"] <= -0.01 + 1e-12
    report: dict = {
        "dataset": str(args.dataset), "split": args.split, "transitions": len(transitions), "successes": int(success.sum()),
        "clearance_at_floor": {"transitions": int(floor.sum()), "successes": int((floor & success).sum())}, "bins": [],
    }
    print(f"{len(transitions)} transitions, {int(success.sum())} successes; clearance at its floor (−1 cm) in "
          f"{int(floor.sum())}, {int((floor & success).sum())} of them successes")
    header = "".join(f" | {name[-24:]:>24s} missed / false" for name in libraries)
    print(f"{'footprint gap (mm)':>20s} {'n':>5s} {'succ':>5s} {'coll':>5s} {'other':>5s}{header}")
    for low, high in itertools.pairwise(EDGES_MM):
        inside = (gap_mm >= low) & (gap_mm < high)
        row = {"low_mm": float(low), "high_mm": float(high), "transitions": int(inside.sum()), "successes": int((inside & success).sum()),
               "collisions": int((inside & collision).sum()), "libraries": {}}
        line = f"{f'[{low:+.0f}, {high:+.0f})':>20s} {row['transitions']:5d} {row['successes']:5d} {row['collisions']:5d} " \
               f"{row['transitions'] - row['successes'] - row['collisions']:5d}"
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
