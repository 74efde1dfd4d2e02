"""Where a placement near contact turns from failure to success: validation Place transitions
re-simulated from their recorded scene with the release height shifted in small steps.

    python benchmarks/contact_threshold.py DATASET [--transitions 200] [--band-mm 3] [--step-mm 0.25]
        [--range-mm 4] [--seed 0] [--json OUT]

Picks ``--transitions`` of the validation transitions (``DATASET/place/validation``) whose release
Place's screen predicts within ``--band-mm`` of the support (its ``support_gap``) and that ended in
success or ``collision``. Each is reset from its recorded scene seed (the observation must match the
recorded one exactly; the simulator is deterministic) and executed again with z shifted by every
step in ±``--range-mm``. Where the outcomes run collision … collision, success … (one turn), the
transition's *critical gap* is the screen's gap at the turn (the midpoint of the two shifts, mm):
how far above the predicted contact the held object must be released. Printed per held object:
how many turned once, the critical gaps' mean and spread; a small spread means the outcome is a
function of the predicted gap, not noise. ``DATASET`` is a directory written by ``t2m datagen``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from support_margin import place_margins

from t2m_core.atomic_files import write_json_atomic
from t2m_core.data.generate import load_split
from t2m_core.data.scenes import data_task
from t2m_core.domain.skills import SkillCall
from t2m_core.errors import T2MError
from t2m_core.registry import get_registry

Z_PER_MM = 2.0 / 100.0
"""Normalised action units per millimetre of release height (Place's z spans [0, 0.1] m over [−1, 1])."""


def critical_gap(gap_mm: float, shifts_mm: np.ndarray, outcomes: list[str]) -> float | None:
    """The gap (mm) at which ``outcomes`` (one per shift, ascending) turn from ``collision`` to
    ``success`` once and stay there; ``None`` for any other pattern."""
    success = np.array([outcome == "success" for outcome in outcomes])
    collision = np.array([outcome == "collision" for outcome in outcomes])
    if not success.any() or success[0]:
        return None
    turn = int(np.argmax(success))
    if not (collision[:turn].all() and success[turn:].all()):
        return None
    return gap_mm + 0.5 * float(shifts_mm[turn - 1] + shifts_mm[turn])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("dataset", type=Path)
    parser.add_argument("--transitions", type=int, default=200)
    parser.add_argument("--band-mm", type=float, default=3.0)
    parser.add_argument("--step-mm", type=float, default=0.25)
    parser.add_argument("--range-mm", type=float, default=4.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", dest="json_out", default=None)
    args = parser.parse_args()
    try:
        transitions = load_split(args.dataset / "place" / "validation")
    except T2MError as error:
        sys.exit(f"error: {error}")
    gaps_mm = place_margins(transitions, ("support_gap",))["support_gap"] * 1000.0
    outcomes = np.array([failure or "success" for failure in transitions.failure_names()])
    band = np.flatnonzero((np.abs(gaps_mm) < args.band_mm) & np.isin(outcomes, ["success", "collision"]))
    chosen = np.random.default_rng(args.seed).choice(band, size=min(args.transitions, len(band)), replace=False)
    shifts = np.arange(-args.range_mm, args.range_mm + 1e-9, args.step_mm)
    simulator = get_registry().create("simulator", "mujoco")
    rows = []
    for row in chosen:
        arguments = transitions.argument_names(row)
        reset = simulator.reset(data_task(int(transitions.symbolic_state[row]), SkillCall("place", arguments)), seed=int(transitions.scene_seed[row]))
        if not np.array_equal(np.asarray(reset.observation, dtype=np.float32), transitions.observation[row]):
            sys.exit(f"error: transition {row} does not reset to its recorded observation; the simulator or its options changed since the data were made")
        snapshot = simulator.get_state()
        shifted = []
        for shift in shifts:
            simulator.set_state(snapshot)
            action = transitions.action[row].astype(np.float64)
            action[2] += shift * Z_PER_MM
            shifted.append(simulator.execute("place", arguments, action).failure or "success")
        rows.append({"row": int(row), "object": arguments[0], "target": arguments[1], "gap_mm": float(gaps_mm[row]),
                     "recorded": str(outcomes[row]), "outcomes": shifted, "critical_gap_mm": critical_gap(float(gaps_mm[row]), shifts, shifted)})
    report = {"dataset": str(args.dataset), "transitions": len(rows), "shifts_mm": shifts.tolist(), "by_object": {}, "rows": rows}
    for name in sorted({row["object"] for row in rows}):
        mine = [row for row in rows if row["object"] == name]
        critical = np.array([row["critical_gap_mm"] for row in mine if row["critical_gap_mm"] is not None])
        summary = {"transitions": len(mine), "turned_once": len(critical)}
        if len(critical):
            summary |= {"critical_gap_mean_mm": float(critical.mean()), "critical_gap_sd_mm": float(critical.std()),
                        "critical_gap_p5_p95_mm": np.percentile(critical, [5, 95]).tolist()}
        report["by_object"][name] = summary
        spread = f"critical gap {summary['critical_gap_mean_mm']:+.2f} mm, sd {summary['critical_gap_sd_mm']:.2f}" if len(critical) else "no single turn"
        print(f"{name:10s} {len(mine):4d} transitions, {len(critical):4d} turn once: {spread}")
    if args.json_out:
        write_json_atomic(args.json_out, report)


if __name__ == "__main__":
    main()
