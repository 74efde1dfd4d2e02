"""Language-model quality and speed on cases built from the 7 tasks.

Cases (the scene of each task sampled for ``--seed``):

- goal: instruction + initial scene -> the task's ground-truth goal alternatives. A prediction is
  correct when its alternatives equal the ground truth as sets (order-free, inside and out).
- next skill: for every prefix of the task's reference skeleton, the next reference skill, with the
  task's ground-truth goal in the prompt and relationships after the prefix from symbolic effects.
  Two candidate sets:
  ``generated`` — the K skills the model proposes (top-5 = the reference skill is among them,
  top-1 = it has the highest score among them);
  ``valid`` — every grounding that is symbolically valid given the described relationships, ranked
  by exact score (top-1 / top-5 by rank).

Each generation question runs once per decoding variant (``free``: plain decoding; ``constrained``:
GBNF grammar from the scene, where the backend supports it; ``grounded``: next skills constrained to
the symbolically valid groundings of the described relationships, goals as ``constrained``).

Speed: model load time; generation tokens/s (64 free tokens, local backends only); milliseconds per
scored candidate once the prompt prefix is cached (goal: under 50 ms).

    python benchmarks/llm_quality.py --llm local --json out/llm_quality.json
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path
from typing import Any

from figure_table import print_figure_table
from rich.console import Console
from rich.progress import Progress

from t2m_core.atomic_files import write_json_atomic
from t2m_core.domain.goals import parse_goal
from t2m_core.language.prompts import K
from t2m_core.language.queries import query_goal, query_next_skills
from t2m_core.language.scene_description import describe_task_scene
from t2m_core.language.selection import create_language_model
from t2m_core.language.session import LanguageSession, valid_groundings
from t2m_core.tasks import list_tasks


def speed(model: Any, session: LanguageSession) -> dict[str, float]:
    """Generation tokens/s and ms per scored candidate on a cached prefix."""
    figures: dict[str, float] = {}
    prompt = "A list of twenty fruit names in Python: ["
    start = time.perf_counter()
    text = model.complete(prompt, max_tokens=64, temperature=0.0)[0]
    elapsed = time.perf_counter() - start
    if hasattr(model, "count_tokens"):
        figures["generation_tokens_per_s"] = model.count_tokens(text) / elapsed
    calls = valid_groundings(session.scene.objects, session.scene.relationships)[:K]
    goal = parse_goal("[['on(rack, table)']]")
    session.score(goal, [], calls)  # evaluates and caches the prefix
    times = []
    for _ in range(10):
        start = time.perf_counter()
        session.score(goal, [], calls)
        times.append(time.perf_counter() - start)
    # the median call: a stray process on a 2-core machine delays single calls by tens of percent
    figures["ms_per_scored_candidate"] = statistics.median(times) * 1000 / len(calls)
    return figures


def goal_cases(model: Any, tasks: list, seed: int, variants: list[str], progress: Progress, cues: bool = True) -> list[dict[str, Any]]:
    rows = []
    variants = [variant for variant in variants if variant != "grounded"]  # "grounded" changes next skills only
    bar = progress.add_task("goal cases", total=len(tasks) * len(variants))
    for task in tasks:
        scene, _ = describe_task_scene(task, seed)
        truth = {frozenset(map(str, alternative)) for alternative in task.goal}
        session = LanguageSession(model, scene, seed=seed)
        cue_text = scene.instruction if cues else None
        for variant in variants:
            start = time.perf_counter()
            query = query_goal(
                model, session.prompts.goal(scene), scene.objects, constrained=variant != "free", instruction=cue_text
            )
            predicted = None if query.goal is None else {frozenset(map(str, a)) for a in query.goal}
            rows.append(
                {
                    "task": task.id,
                    "variant": variant,
                    "valid": query.goal is not None,
                    "first_answer_valid": query.attempts[0].problem is None,
                    "correct": predicted == truth,
                    "goal": None if query.goal is None else query.goal.to_lists(),
                    "answers": [attempt.answer for attempt in query.attempts],
                    "seconds": time.perf_counter() - start,
                }
            )
            progress.advance(bar)
    return rows


def next_cases(model: Any, tasks: list, seed: int, variants: list[str], progress: Progress, limit: int | None) -> list[dict[str, Any]]:
    cases = [(task, length) for task in tasks for length in range(len(task.reference_skeleton))]
    if limit is not None:
        cases = cases[:limit]
    rows = []
    bar = progress.add_task("next-skill cases", total=len(cases))
    sessions: dict[str, LanguageSession] = {}
    for task, length in cases:
        if task.id not in sessions:
            scene, _ = describe_task_scene(task, seed)
            sessions[task.id] = LanguageSession(model, scene, seed=seed)
        session = sessions[task.id]
        executed = list(task.reference_skeleton[:length])
        target = task.reference_skeleton[length]
        row: dict[str, Any] = {"task": task.id, "prefix": length, "target": str(target)}
        prompt = session.prompts.next_skill(session.scene, task.goal, session.history(executed))
        valid = valid_groundings(session.scene.objects, session.current_relationships(executed))
        for variant in variants:
            start = time.perf_counter()
            candidates, attempts = query_next_skills(
                model,
                prompt,
                session.scene.objects,
                K,
                constrained=variant != "free",
                calls=[str(call) for call in valid] if variant == "grounded" else None,
            )
            scored = session.score(task.goal, executed, candidates.calls)
            ranked = [call for call, _, _ in scored.ranked()]
            row[variant] = {
                "parsed": bool(candidates.calls),
                "first_answer_parsed": attempts[0].problem is None,
                "candidates": [str(call) for call in candidates.calls],
                "rejected": len(candidates.rejected),
                "top1": bool(ranked) and ranked[0] == target,
                "top5": target in ranked[:5],
                "seconds": time.perf_counter() - start,
            }
        scored = session.score(task.goal, executed, valid)
        ranked = [call for call, _, _ in scored.ranked()]
        row["valid"] = {
            "size": len(valid),
            "contains_target": target in valid,
            "ranking": [str(call) for call in ranked],
            "top1": bool(ranked) and ranked[0] == target,
            "top5": target in ranked[:5],
        }
        rows.append(row)
        progress.advance(bar)
    return rows


def summarise(goals: list[dict[str, Any]], nexts: list[dict[str, Any]], variants: list[str]) -> dict[str, Any]:
    summary: dict[str, Any] = {}
    for variant in variants:
        rows = [row for row in goals if row["variant"] == variant]
        if rows:
            summary[f"goal_accuracy_{variant}"] = sum(row["correct"] for row in rows) / len(rows)
            summary[f"goal_valid_share_{variant}"] = sum(row["valid"] for row in rows) / len(rows)
            summary[f"goal_first_answer_valid_share_{variant}"] = sum(row["first_answer_valid"] for row in rows) / len(rows)
        if nexts:
            summary[f"next_parse_share_{variant}"] = sum(row[variant]["parsed"] for row in nexts) / len(nexts)
            summary[f"next_top1_generated_{variant}"] = sum(row[variant]["top1"] for row in nexts) / len(nexts)
            summary[f"next_top5_generated_{variant}"] = sum(row[variant]["top5"] for row in nexts) / len(nexts)
    if nexts:
        summary["next_top1_valid_set"] = sum(row["valid"]["top1"] for row in nexts) / len(nexts)
        summary["next_top5_valid_set"] = sum(row["valid"]["top5"] for row in nexts) / len(nexts)
        summary["valid_set_mean_size"] = statistics.fmean(row["valid"]["size"] for row in nexts)
        summary["next_cases"] = len(nexts)
    summary["goal_cases_per_variant"] = len(goals) // max(len({row["variant"] for row in goals}), 1)
    return summary


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--llm", default="local", help="language model name (default: local)")
    parser.add_argument("--set", dest="settings", action="append", default=[], help="model option KEY=VALUE")
    parser.add_argument("--seed", type=int, default=0, help="scene seed and example order")
    parser.add_argument("--tasks", default="", help="comma-separated task ids (default: all 7)")
    parser.add_argument("--variants", default="free,constrained,grounded", help="decoding variants to compare (free, constrained, grounded)")
    parser.add_argument("--skip-goals", action="store_true")
    parser.add_argument("--skip-next", action="store_true")
    parser.add_argument("--max-next-cases", type=int, default=None)
    parser.add_argument("--no-cues", action="store_true", help="goal answers without the instruction's relation and count cues")
    parser.add_argument("--transcript", type=Path, default=None, help="record every request (JSONL)")
    parser.add_argument("--json", dest="json_out", type=Path, required=True, help="write the figures here")
    args = parser.parse_args(argv)

    from t2m_core.config.resolve import parse_override

    options = {}
    for text in args.settings:
        path, value = parse_override(text)
        options[".".join(path)] = value
    tasks = [task for task in list_tasks() if not args.tasks or task.id in args.tasks.split(",")]
    variants = [variant for variant in args.variants.split(",") if variant]

    start = time.perf_counter()
    model = create_language_model(args.llm, options, transcript=args.transcript)
    load_time_s = time.perf_counter() - start
    inner = getattr(model, "model", model)
    figures: dict[str, Any] = {"llm": args.llm, "seed": args.seed, "instruction_cues": not args.no_cues, "load_time_s": load_time_s, "cpu_count": os.cpu_count()}
    figures["exact_scoring"] = model.capabilities.exact_scoring
    with Progress(console=Console(stderr=True), transient=True) as progress:
        first_scene, _ = describe_task_scene(tasks[0], args.seed)
        figures.update(speed(inner, LanguageSession(inner, first_scene, seed=args.seed)))
        goals = [] if args.skip_goals else goal_cases(model, tasks, args.seed, variants, progress, cues=not args.no_cues)
        nexts = [] if args.skip_next else next_cases(model, tasks, args.seed, variants, progress, args.max_next_cases)
    figures["load_average_1min"] = os.getloadavg()[0]
    figures["wall_s"] = time.perf_counter() - start
    figures["summary"] = summarise(goals, nexts, variants)
    figures["goal_cases"] = goals
    figures["next_cases"] = nexts
    args.json_out.parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(args.json_out, figures)

    speeds = {key: figures[key] for key in ("load_time_s", "generation_tokens_per_s", "ms_per_scored_candidate") if key in figures}
    print_figure_table(
        f"llm_quality --llm {args.llm} (seed {args.seed})", {**speeds, **figures["summary"]}, digits=dict.fromkeys(speeds, 2)
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
