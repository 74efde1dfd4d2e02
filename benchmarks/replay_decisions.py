"""Does an episode replayed from its transcript take the same decisions? Every episode of a `t2m eval` directory.

    python benchmarks/replay_decisions.py EVAL_DIR --json OUT [--tasks task0,task3] [--seeds 0-2] [--work DIR]

Each finished episode of ``EVAL_DIR`` (``<planner>/<task>/seed<N>/``) is run again with its own
recorded configuration, the language model swapped for the ``replay`` backend answering from the
episode's ``transcript.jsonl`` (docs/guide/run-records.md). The replay must ask exactly the recorded
questions, in order (the replay backend refuses any other), and it is compared with the recording:

- the plan tree: every record of ``plan_tree.jsonl`` (goal, shooting candidates, greedy steps with
  their scores and STAP values, backtracks, the plan, each executed step with its action, values
  and outcome), less the wall-clock fields (``*_seconds``);
- the result: plan, success, failure type and reason, predicted goal, LLM and STAP calls, subgoal
  completion.

An episode matches only when all of it is equal. Prints one line per episode and a summary, and
writes them as JSON with the replays' wall time against the recordings'.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path
from typing import Any

import yaml

RESULT_KEYS = ("plan", "success", "failure_type", "failure", "predicted_goal", "llm_calls", "stap_calls", "subgoal_completion")


def without_timings(record: Any) -> Any:
    """``record`` with every ``*_seconds`` key removed, recursively."""
    if isinstance(record, dict):
        return {k: without_timings(v) for k, v in record.items() if not k.endswith("_seconds")}
    if isinstance(record, list):
        return [without_timings(v) for v in record]
    return record


def first_difference(recorded: list[dict[str, Any]], replayed: list[dict[str, Any]]) -> str | None:
    """Where two plan trees part: the first differing record, or ``None`` when they are equal."""
    recorded, replayed = without_timings(recorded), without_timings(replayed)
    for index, (a, b) in enumerate(zip(recorded, replayed, strict=False)):
        if a != b:
            keys = sorted(k for k in set(a) | set(b) if a.get(k) != b.get(k))
            return f"record {index + 1} ({a.get('event')}) differs in {', '.join(keys)}"
    if len(recorded) != len(replayed):
        return f"{len(recorded)} records recorded, {len(replayed)} replayed"
    return None


def seed_index(directory: Path) -> int:
    """The seed index of an evaluation's run directory ``<planner>/<task>/seed<N>``."""
    return int(directory.name.removeprefix("seed"))


def replay_config(directory: Path, work: Path):
    """The episode's recorded configuration with the language model replaced by its transcript."""
    from t2m_core.config.resolve import resolve_config
    from t2m_core.registry import get_registry

    recorded = yaml.safe_load((directory / "config.yaml").read_text(encoding="utf-8"))
    recorded["language_model"] = {"name": "replay", "options": {"transcript": str((directory / "transcript.jsonl").resolve())}}
    path = work / "config.yaml"
    path.write_text(yaml.safe_dump(recorded, sort_keys=False), encoding="utf-8")
    return resolve_config([path], registry=get_registry())


def replay(directory: Path, work: Path) -> dict[str, Any]:
    """Replay one recorded episode into ``work`` and compare it with the recording."""
    from t2m_core.episode import run_episode
    from t2m_core.run_records import read_plan_tree, read_result

    recorded = read_result(directory)
    assert recorded is not None, directory
    work.mkdir(parents=True, exist_ok=True)
    config = replay_config(directory, work)
    started = time.perf_counter()
    try:
        result = run_episode(config, work / "run").as_dict()
        error = None
    except Exception as failure:  # noqa: BLE001 - a replay that asks an unrecorded question is a mismatch, reported
        result, error = {}, f"{type(failure).__name__}: {failure}"
    seconds = time.perf_counter() - started
    tree = first_difference(read_plan_tree(directory), read_plan_tree(work / "run")) if error is None else error
    results = [k for k in RESULT_KEYS if recorded.get(k) != result.get(k)] if error is None else list(RESULT_KEYS)
    return {
        "task": recorded["task"], "seed_index": seed_index(directory), "planner": recorded["planner"],
        "success": recorded["success"], "matches": tree is None and not results, "plan_tree_difference": tree,
        "result_differences": results, "recorded_seconds": recorded["timings"]["total"], "replay_seconds": round(seconds, 2),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("evaluation", type=Path, help="a t2m eval directory")
    parser.add_argument("--json", dest="json_out", required=True)
    parser.add_argument("--tasks", default=None, help="comma-separated task ids (default: all recorded)")
    parser.add_argument("--seeds", default=None, help="seed indices, 0-9 or 0,3,5 (default: all recorded)")
    parser.add_argument("--work", type=Path, default=None, help="where the replays are written (default: a temporary directory)")
    args = parser.parse_args()

    from t2m_core.atomic_files import write_json_atomic
    from t2m_core.evaluation import parse_seed_indices
    from t2m_core.run_records import episode_results

    tasks = None if args.tasks is None else set(args.tasks.split(","))
    seeds = None if args.seeds is None else set(parse_seed_indices(args.seeds))
    episodes = [(d, r) for d, r in episode_results(args.evaluation)
                if (tasks is None or r["task"] in tasks) and (seeds is None or seed_index(d) in seeds)]
    if not episodes:
        raise SystemExit(f"no finished episodes in {args.evaluation} match --tasks/--seeds")
    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        work = args.work or Path(scratch)
        for directory, _ in episodes:
            row = replay(directory, work / directory.relative_to(args.evaluation))
            rows.append(row)
            verdict = "same decisions" if row["matches"] else f"DIFFERS: {row['plan_tree_difference'] or row['result_differences']}"
            print(f"{row['planner']} {row['task']} seed {row['seed_index']}: {verdict} "
                  f"(replay {row['replay_seconds']:.0f} s, recorded {row['recorded_seconds']:.0f} s)", flush=True)
    matched = sum(r["matches"] for r in rows)
    summary = {"episodes": len(rows), "matched": matched, "replay_seconds": round(sum(r["replay_seconds"] for r in rows), 1),
               "recorded_seconds": round(sum(r["recorded_seconds"] for r in rows), 1)}
    print(f"{matched} of {len(rows)} replayed episodes took the recorded decisions "
          f"({summary['replay_seconds']:.0f} s replayed against {summary['recorded_seconds']:.0f} s recorded)")
    write_json_atomic(args.json_out, {"evaluation": str(args.evaluation), "summary": summary, "episodes": rows})
    if matched != len(rows):
        raise SystemExit(1)


if __name__ == "__main__":
    main()
