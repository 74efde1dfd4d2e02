"""Semantic goal accuracy of a language model on the goal evaluation set and on the task suite
(docs/guide/language-models.md#measuring-quality).

Each case's scene is sampled for ``--seed`` and its goal predicted as ``t2m llm goal`` does
(``LanguageSession.predict_goal``). A prediction is judged on the states reachable from the scene's
symbolic initial state within d_max = 10 skills (``t2m_core.language.goal_judging``): *strict* when
it accepts the same states as the truth, *plan-level* when every shortest plan to it reaches the
truth; "no valid goal" is right exactly when the truth is no goal.

    python benchmarks/llm_goals.py --llm local --json out/goals_05b.json
    python benchmarks/llm_goals.py --llm local --set model=qwen2.5-coder-1.5b --no-cues --json out/goals_15b_nocues.json
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections import defaultdict
from pathlib import Path
from typing import Any

from figure_table import print_figure_table
from rich.console import Console

from t2m_core.atomic_files import write_json_atomic
from t2m_core.language.goal_cases import describe_case, initial_facts, load_goal_cases, load_heldout_cases
from t2m_core.language.goal_judging import judge_goal, reachable_states
from t2m_core.language.scene_description import describe_task_scene
from t2m_core.language.selection import create_language_model
from t2m_core.language.session import LanguageSession
from t2m_core.tasks import list_tasks
from t2m_core.tasks.symbolic_model import initial_facts as task_facts


def cases(sets: list[str], seed: int) -> list[dict[str, Any]]:
    """``{set, id, tags, scene, truth, facts, objects}`` per case, scenes sampled for ``seed``."""
    rows = []
    for name, load in (("new", load_goal_cases), ("heldout", load_heldout_cases)):
        if name not in sets:
            continue
        for case in load():
            rows.append({"set": name, "id": case.id, "tags": list(case.tags), "scene": describe_case(case, seed),
                         "truth": case.goal, "no_goal": case.no_goal, "facts": initial_facts(case.scene),
                         "objects": case.scene.objects, "scene_name": case.scene.name})
    if "suite" in sets:
        for task in list_tasks():
            scene, _ = describe_task_scene(task, seed)
            rows.append({"set": "suite", "id": task.id, "tags": list(task.properties), "scene": scene, "truth": task.goal,
                         "no_goal": None, "facts": task_facts(task), "objects": task.objects, "scene_name": task.id})
    return rows


def run(model: Any, rows: list[dict[str, Any]], seed: int, cues: bool, console: Console) -> list[dict[str, Any]]:
    results, reachable = [], {}
    for row in rows:
        key = (row["set"], row["scene_name"])
        if key not in reachable:
            reachable[key] = reachable_states(row["facts"], row["objects"])
        session = LanguageSession(model, row["scene"], seed=seed, cues=cues)
        start = time.perf_counter()
        query = session.predict_goal()
        seconds = time.perf_counter() - start
        judgement = judge_goal(query.goal, row["truth"], reachable[key])
        unpreferred = judge_goal(query.unpreferred, row["truth"], reachable[key]) if query.goal is not None else judgement
        result = {
            "set": row["set"], "id": row["id"], "tags": row["tags"], "instruction": row["scene"].instruction,
            "truth": None if row["truth"] is None else row["truth"].to_lists(), "truth_no_goal": row["no_goal"],
            "goal": None if query.goal is None else query.goal.to_lists(),
            "no_goal": None if query.no_goal is None else {"kind": query.no_goal.kind, "reason": query.no_goal.reason},
            "answers": [attempt.answer for attempt in query.attempts],
            "strict": judgement.strict, "plan_level": judgement.plan_level, "seconds": seconds,
            "without_named_preference": {"strict": unpreferred.strict, "plan_level": unpreferred.plan_level},
        }
        results.append(result)
        mark = "ok" if result["strict"] else ("plan" if result["plan_level"] else "WRONG")
        console.print(f"{row['set']} {row['id']} {mark:5} {seconds:5.1f}s  {row['scene'].instruction}  ->  "
                      f"{result['goal'] if query.goal else (query.no_goal.kind if query.no_goal else 'invalid')}", highlight=False)
    return results


def summarise(results: list[dict[str, Any]]) -> dict[str, Any]:
    summary: dict[str, Any] = {}
    for name in sorted({row["set"] for row in results}):
        rows = [row for row in results if row["set"] == name]
        summary[f"{name}_cases"] = len(rows)
        summary[f"{name}_strict"] = sum(row["strict"] for row in rows) / len(rows)
        summary[f"{name}_plan_level"] = sum(row["plan_level"] for row in rows) / len(rows)
        unpreferred = [row["without_named_preference"] for row in rows]
        summary[f"{name}_strict_without_named_preference"] = sum(row["strict"] for row in unpreferred) / len(rows)
        summary[f"{name}_plan_level_without_named_preference"] = sum(row["plan_level"] for row in unpreferred) / len(rows)
        by_tag: dict[str, list[bool]] = defaultdict(list)
        for row in rows:
            for tag in row["tags"]:
                by_tag[tag].append(row["plan_level"])
        summary[f"{name}_plan_level_by_tag"] = {tag: f"{sum(v)}/{len(v)}" for tag, v in sorted(by_tag.items())}
        summary[f"{name}_median_seconds"] = sorted(row["seconds"] for row in rows)[len(rows) // 2]
    return summary


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--llm", default="local")
    parser.add_argument("--set", dest="settings", action="append", default=[], help="model option KEY=VALUE")
    parser.add_argument("--seed", type=int, default=0, help="scene seed and example order")
    parser.add_argument("--sets", default="new,suite", help="new (the goal evaluation set), heldout (the held-out set, kept out of tuning), suite (the 7 tasks)")
    parser.add_argument("--ids", default="", help="comma-separated case ids to run (default: all)")
    parser.add_argument("--no-cues", action="store_true", help="goal answers without the instruction cues")
    parser.add_argument("--json", dest="json_out", type=Path, required=True)
    args = parser.parse_args(argv)

    from t2m_core.config.resolve import parse_override

    options = {}
    for text in args.settings:
        path, value = parse_override(text)
        options[".".join(path)] = value
    rows = cases([name for name in args.sets.split(",") if name], args.seed)
    if args.ids:
        rows = [row for row in rows if row["id"] in args.ids.split(",")]
    console = Console(stderr=True)
    start = time.perf_counter()
    model = create_language_model(args.llm, options)
    results = run(model, rows, args.seed, not args.no_cues, console)
    figures = {"llm": args.llm, "options": options, "seed": args.seed, "instruction_cues": not args.no_cues,
               "cpu_count": os.cpu_count(), "load_average_1min": os.getloadavg()[0], "wall_s": time.perf_counter() - start,
               "summary": summarise(results), "cases": results}
    args.json_out.parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(args.json_out, figures)

    cue_text = "with" if not args.no_cues else "without"
    print_figure_table(f"goal accuracy, {args.llm} {options or ''}, {cue_text} cues, seed {args.seed}", figures["summary"])
    return 0


if __name__ == "__main__":
    sys.exit(main())
