"""Compare two evaluations episode by episode, from the ``episodes.csv`` that ``t2m eval`` writes.

    python benchmarks/compare_evaluations.py BASE_DIR NEW_DIR [--json OUT]

For the episodes both hold (same planner, task and seed index): success per task and planner before
and after, and every episode whose outcome, failure, plan, language-model calls or STAP plans
changed. Seconds are not compared (they depend on the load). Prints a table and the changed
episodes; writes JSON. Exits 1 when the two share no episode.
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

COMPARED = ("success", "failure", "plan", "llm_calls", "stap_calls")
"""The columns whose change marks an episode as changed."""


def read_episodes(directory: Path) -> dict[tuple[str, str, str], dict[str, str]]:
    """An evaluation's ``episodes.csv`` keyed by (planner, task, seed index)."""
    path = directory / "episodes.csv"
    if not path.exists():
        raise SystemExit(f"{path} does not exist: give an evaluation directory written by `t2m eval`")
    with path.open(newline="", encoding="utf-8") as handle:
        return {(row["planner"], row["task"], row["seed_index"]): row for row in csv.DictReader(handle)}


def compare(base: dict[tuple[str, str, str], dict[str, str]], new: dict[tuple[str, str, str], dict[str, str]]) -> dict:
    """Per (planner, task): episodes and successes before and after; the changed episodes."""
    shared = sorted(set(base) & set(new), key=lambda key: (key[0], key[1], int(key[2])))
    tasks: dict[str, dict[str, int]] = {}
    changed = []
    for key in shared:
        before, after = base[key], new[key]
        summary = tasks.setdefault(f"{key[0]} {key[1]}", {"episodes": 0, "success_before": 0, "success_after": 0})
        summary["episodes"] += 1
        summary["success_before"] += before["success"] == "True"
        summary["success_after"] += after["success"] == "True"
        differences = {column: {"before": before[column], "after": after[column]} for column in COMPARED if before[column] != after[column]}
        if differences:
            changed.append({"planner": key[0], "task": key[1], "seed_index": int(key[2]), "changes": differences})
    return {
        "episodes": len(shared),
        "unchanged": len(shared) - len(changed),
        "success_before": sum(t["success_before"] for t in tasks.values()),
        "success_after": sum(t["success_after"] for t in tasks.values()),
        "tasks": tasks,
        "changed": changed,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("base", type=Path, help="the evaluation directory compared against")
    parser.add_argument("new", type=Path, help="the evaluation directory compared")
    parser.add_argument("--json", dest="json_out", type=Path, default=None)
    args = parser.parse_args()
    report = compare(read_episodes(args.base), read_episodes(args.new))
    report.update(base=str(args.base), new=str(args.new))
    if report["episodes"] == 0:
        print(f"{args.base} and {args.new} share no episode (planner, task, seed index)", file=sys.stderr)
        sys.exit(1)

    from rich.console import Console
    from rich.table import Table

    table = Table(title=f"{report['episodes']} shared episodes, {report['unchanged']} unchanged")
    for column in ("planner, task", "episodes", "success before", "success after"):
        table.add_column(column, justify="right")
    for name, summary in report["tasks"].items():
        table.add_row(name, str(summary["episodes"]), str(summary["success_before"]), str(summary["success_after"]))
    table.add_row("all", str(report["episodes"]), str(report["success_before"]), str(report["success_after"]))
    console = Console()
    console.print(table)
    for episode in report["changed"]:
        what = "; ".join(f"{column} {change['before'][:60]!r} -> {change['after'][:60]!r}" for column, change in episode["changes"].items())
        console.print(f"{episode['planner']} {episode['task']} seed {episode['seed_index']}: {what}", highlight=False)
    if args.json_out:
        from t2m_core.atomic_files import write_json_atomic

        write_json_atomic(args.json_out, report)


if __name__ == "__main__":
    main()
