"""Time of the language queries a planning episode makes, first in a process and after the first,
in a process with an empty prompt-state cache and in a new process with a warm one
(docs/guide/language-models.md#prompts-paid-for-once).

One episode of ``--task`` / ``--seed``: the goal query, then for every prefix of the task's
reference skeleton a planner query (K next skills generated, then scored), then the goal query
again. It runs twice, each time in a new process: ``cold`` with an empty prompt-state cache
(``T2M_CACHE_DIR`` pointed at a new directory; the model file is passed by path), ``warm`` with
the cache the cold run left.

    python benchmarks/llm_query_times.py --llm local --json out/query_times_05b.json
    python benchmarks/llm_query_times.py --llm local --set model=qwen2.5-coder-1.5b --json out/query_times_15b.json
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from rich.console import Console
from rich.table import Table

from t2m_core.atomic_files import write_json_atomic


def _model_path(options: dict[str, Any]) -> str:
    """The GGUF file the options select (assembled and verified in the real cache if needed)."""
    if options.get("model_path"):
        return str(options["model_path"])
    from t2m_llm_local import model_files

    if "model" in options:
        return str(model_files.embedded_model_path(options["model"]))
    return str(model_files.default_model_path())


def episode(llm: str, options: dict[str, Any], task_id: str, seed: int) -> dict[str, Any]:
    """Run one episode's queries in this process; seconds per query."""
    from t2m_core.language.scene_description import describe_task_scene
    from t2m_core.language.selection import create_language_model
    from t2m_core.language.session import LanguageSession
    from t2m_core.tasks import load_task

    task = load_task(task_id)
    scene, _ = describe_task_scene(task, seed)
    start = time.perf_counter()
    model = create_language_model(llm, options)
    figures: dict[str, Any] = {"load_s": time.perf_counter() - start}
    session = LanguageSession(model, scene, seed=seed)

    def timed(call):
        began = time.perf_counter()
        result = call()
        return result, time.perf_counter() - began

    query, figures["goal_first_s"] = timed(session.predict_goal)
    figures["goal_valid"] = query.goal is not None
    steps = []
    for length in range(len(task.reference_skeleton)):
        executed = list(task.reference_skeleton[:length])
        (calls, attempts), generate_s = timed(lambda executed=executed: session.generate_next(task.goal, executed))
        _, score_s = timed(lambda executed=executed, calls=calls: session.score(task.goal, executed, calls))
        steps.append({"prefix": length, "candidates": len(calls), "generate_s": generate_s, "score_s": score_s})
    _, figures["goal_again_s"] = timed(session.predict_goal)
    figures["steps"] = steps
    figures["planner_first_s"] = steps[0]["generate_s"] + steps[0]["score_s"]
    later = steps[1:]
    if later:
        figures["planner_after_first_median_s"] = statistics.median(step["generate_s"] + step["score_s"] for step in later)
        figures["planner_after_first_max_s"] = max(step["generate_s"] + step["score_s"] for step in later)
        figures["score_after_first_median_s"] = statistics.median(step["score_s"] for step in later)
    return figures


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--llm", default="local")
    parser.add_argument("--set", dest="settings", action="append", default=[], help="model option KEY=VALUE")
    parser.add_argument("--task", default="task3")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", dest="json_out", type=Path, required=True)
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)

    from t2m_core.config.resolve import parse_override

    options: dict[str, Any] = {}
    for text in args.settings:
        path, value = parse_override(text)
        options[".".join(path)] = value
    if args.child:
        write_json_atomic(args.json_out, episode(args.llm, options, args.task, args.seed))
        return 0

    model_path = _model_path(options)
    runs: dict[str, Any] = {}
    with tempfile.TemporaryDirectory(prefix="t2m-prompt-states-") as cache:
        for phase in ("cold", "warm"):
            out = Path(cache) / f"{phase}.json"
            command = [sys.executable, __file__, "--child", "--llm", args.llm, "--task", args.task, "--seed", str(args.seed),
                       "--json", str(out), *[f"--set={text}" for text in args.settings if not text.startswith("model=")],
                       f"--set=model_path={model_path}"]
            subprocess.run(command, check=True, env={**os.environ, "T2M_CACHE_DIR": cache})
            runs[phase] = json.loads(out.read_text())
    figures = {"llm": args.llm, "options": options, "model_path": model_path, "task": args.task, "seed": args.seed,
               "cpu_count": os.cpu_count(), "load_average_1min": os.getloadavg()[0], "runs": runs}
    args.json_out.parent.mkdir(parents=True, exist_ok=True)
    write_json_atomic(args.json_out, figures)

    table = Table(title=f"query times, {args.llm} {options or ''} ({args.task}, seed {args.seed}), seconds", title_justify="left")
    table.add_column("query")
    for phase in runs:
        table.add_column(f"{phase} prompt cache", justify="right")
    rows = [("model load", "load_s"), ("goal, first", "goal_first_s"), ("goal, again", "goal_again_s"),
            ("planner query (generate + score), first", "planner_first_s"),
            ("planner query after the first, median", "planner_after_first_median_s"),
            ("planner query after the first, max", "planner_after_first_max_s"),
            ("scoring after the first, median", "score_after_first_median_s")]
    for label, key in rows:
        table.add_row(label, *(f"{run[key]:.2f}" if key in run else "-" for run in runs.values()))
    Console().print(table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
