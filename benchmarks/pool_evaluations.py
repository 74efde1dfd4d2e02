"""Pool evaluations of disjoint seed sets into one success table, with 95 % Wilson intervals.

    python benchmarks/pool_evaluations.py EVAL_DIR [EVAL_DIR ...] [--json OUT]

Reads each directory's ``episodes.csv`` (written by ``t2m eval``). Per planner and task, and over all
tasks: episodes, successes, the success rate and its 95 % Wilson score interval, so that a figure
such as "80 % against the paper's 82 %" comes with how far 70 or 210 episodes pin it down. Exits 1
when an episode (planner, task, seed index) appears in two directories: pooled sets must not share
a scene.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from compare_evaluations import read_episodes

Z_95 = 1.959964
"""The standard normal quantile of a two-sided 95 % interval."""


def wilson_interval(successes: int, trials: int, z: float = Z_95) -> tuple[float, float]:
    """The Wilson score interval of a binomial success rate, (low, high) in [0, 1]."""
    if trials == 0:
        return (0.0, 1.0)
    rate = successes / trials
    centre = rate + z * z / (2 * trials)
    spread = z * math.sqrt(rate * (1 - rate) / trials + z * z / (4 * trials * trials))
    denominator = 1 + z * z / trials
    return (max(0.0, (centre - spread) / denominator), min(1.0, (centre + spread) / denominator))


def pool(evaluations: list[tuple[str, dict[tuple[str, str, str], dict[str, str]]]]) -> dict:
    """Success per (planner, task) and per planner over all tasks, pooled over the (name, episodes)
    of each evaluation.

    Raises:
        ValueError: an episode appears in two evaluations.
    """
    seen: dict[tuple[str, str, str], str] = {}
    counts: dict[tuple[str, str], list[int]] = {}
    for name, episodes in evaluations:
        for key, row in episodes.items():
            if key in seen:
                raise ValueError(f"{key[0]} {key[1]} seed index {key[2]} is in both {seen[key]} and {name}")
            seen[key] = name
            for task in (key[1], "all"):
                tally = counts.setdefault((key[0], task), [0, 0])
                tally[0] += row["success"] == "True"
                tally[1] += 1
    rows = []
    for (planner, task), (successes, episodes) in sorted(counts.items(), key=lambda item: (item[0][0], item[0][1] == "all", item[0][1])):
        low, high = wilson_interval(successes, episodes)
        rows.append({"planner": planner, "task": task, "episodes": episodes, "success": successes,
                     "rate": successes / episodes, "interval_95": [low, high]})
    return {"evaluations": [name for name, _ in evaluations], "rows": rows}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("evaluations", type=Path, nargs="+", help="evaluation directories of `t2m eval` (or copies of their tables)")
    parser.add_argument("--json", dest="json_out", type=Path, default=None)
    args = parser.parse_args()
    try:
        report = pool([(str(directory), read_episodes(directory)) for directory in args.evaluations])
    except ValueError as error:
        print(f"cannot pool: {error}; pass evaluations of disjoint seed sets", file=sys.stderr)
        sys.exit(1)

    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"pooled over {len(args.evaluations)} evaluation(s)")
    for column in ("planner", "task", "episodes", "success", "rate", "95 % interval"):
        table.add_column(column, justify="right")
    for row in report["rows"]:
        low, high = row["interval_95"]
        table.add_row(row["planner"], row["task"], str(row["episodes"]), str(row["success"]), f"{row['rate']:.1%}", f"{low:.1%} – {high:.1%}")
    Console().print(table)
    if args.json_out:
        from t2m_core.atomic_files import write_json_atomic

        write_json_atomic(args.json_out, report)


if __name__ == "__main__":
    main()
