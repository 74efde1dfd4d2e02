"""Where a placed object falls: Place's ``support_margin`` measured at the held object's centre of mass
(what the screen reads) and at its origin (what it read before), and its ``balance_margin`` (the
centre of mass inside the part of the object's resting hull that the target holds up), against each
transition's outcome.

    python benchmarks/support_margin.py DATASET [--split validation] [--json OUT]

For each kind of call (``place(hook, table)``, ``place(box, rack)``, ...) and each margin, the
transitions in bins of the margin (metres; negative: beyond the target's edge) with their success
and ``below_table`` rates. A margin that tells where the object falls leaves no success below 0.
The hook's centre of mass lies 8 cm from its origin (docs/guide/world.md#frames-and-objects); a
box's is its origin, so its first two margins agree. A hook whose head overhangs the edge rolls
about its handle although its centre of mass lies inside the top: only the balance margin sees it.
``DATASET`` is a directory written by ``t2m datagen`` (``DATASET/place/<split>``).
"""

from __future__ import annotations

import argparse
import itertools
import sys
from pathlib import Path
from unittest import mock

import numpy as np
from geometric_prediction import call_kinds

from t2m_core.atomic_files import write_json_atomic
from t2m_core.data.generate import load_split
from t2m_core.data.records import Transitions
from t2m_core.domain.objects import ObjectSpec
from t2m_core.domain.observation import decode_observation
from t2m_core.domain.primitives import get_primitive
from t2m_core.errors import T2MError

EDGES = (-np.inf, -0.02, 0.0, 0.01, 0.02, 0.05, np.inf)
"""Bin edges of the margin, metres."""


def place_margins(transitions: Transitions, predictions: tuple[str, ...] = ("support_margin",)) -> dict[str, np.ndarray]:
    """``{prediction: (N,)}`` Place's margins (metres) of each transition's decoded state and action
    (:func:`screen_margins`)."""
    return screen_margins("place", transitions, predictions)


def screen_margins(skill: str, transitions: Transitions, predictions: tuple[str, ...]) -> dict[str, np.ndarray]:
    """``{prediction: (N,)}`` a primitive's screen predictions of each transition's decoded state and
    action, every prediction from one screen call per transition."""
    primitive = get_primitive(skill)
    physical = primitive.to_physical(np.asarray(transitions.action, dtype=np.float64))
    margins = {name: np.empty(len(transitions)) for name in predictions}
    for row in range(len(transitions)):
        state = decode_observation(transitions.observation[row], transitions.object_names(row))
        screen = primitive.screen_of_states([state], transitions.argument_names(row), physical[row][None], np.zeros(1, dtype=np.int64))
        for name in predictions:
            margins[name][row] = screen[name][0]
    return margins


def origin_margins(transitions: Transitions) -> np.ndarray:
    """``(N,)`` the same margin measured at the held object's origin (the screen before it read the
    centre of mass): every object's centre of mass put at its origin."""
    with mock.patch.object(ObjectSpec, "centre_of_mass", lambda self: np.zeros(3)):
        return place_margins(transitions)["support_margin"]


def binned(margins: np.ndarray, success: np.ndarray, outcomes: np.ndarray) -> list[dict]:
    """Per bin of :data:`EDGES`: its bounds, transitions, success and ``below_table`` rates."""
    rows = []
    for low, high in itertools.pairwise(EDGES):
        inside = (margins >= low) & (margins < high)
        if inside.any():
            rows.append({"low_m": float(low), "high_m": float(high), "transitions": int(inside.sum()),
                         "success": float(success[inside].mean()), "below_table": float((outcomes[inside] == "below_table").mean())})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("dataset", type=Path)
    parser.add_argument("--split", default="validation")
    parser.add_argument("--json", dest="json_out", default=None)
    args = parser.parse_args()
    try:
        transitions = load_split(args.dataset / "place" / args.split)
    except T2MError as error:
        sys.exit(f"error: {error}")
    outcomes = np.array([failure or "success" for failure in transitions.failure_names()])
    kinds = call_kinds("place", transitions)
    measured = place_margins(transitions, ("support_margin", "balance_margin"))
    margins = {"centre_of_mass": measured["support_margin"], "origin": origin_margins(transitions), "balance": measured["balance_margin"]}
    report: dict = {"dataset": str(args.dataset), "split": args.split, "transitions": len(transitions), "by_call": {}}
    for kind in sorted(set(kinds.tolist())):
        mine = kinds == kind
        report["by_call"][kind] = {name: binned(values[mine], transitions.success[mine], outcomes[mine]) for name, values in margins.items()}
        print(f"{kind}: {int(mine.sum())} transitions")
        for name, rows in report["by_call"][kind].items():
            for row in rows:
                print(f"  {name:15s} [{row['low_m']:+.2f}, {row['high_m']:+.2f}) m  {row['transitions']:5d}  "
                      f"success {row['success']:.2f}  below_table {row['below_table']:.2f}")
    if args.json_out:
        write_json_atomic(args.json_out, report)


if __name__ == "__main__":
    main()
