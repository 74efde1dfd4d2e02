"""Does an episode replayed from its transcript take the same decisions? Every episode of a `t2m eval` directory.

    python benchmarks/replay_decisions.py EVAL_DIR --json OUT [--tasks task0,task3] [--seeds 0-2] [--work DIR]
    python benchmarks/replay_decisions.py EVAL_DIR --json OUT --set KEY=VALUE [--calls "place(hook, table)"] [--workers 2]

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
writes them as JSON with the replays' wall time against the recordings'. Exits 1 when one differs.

**What if.** With ``--set`` (config overrides, as ``t2m eval --set``) the episodes are replayed under
a changed configuration, and the question becomes their outcome: a change that leaves the language
model's questions as recorded (an option of the closed loop's re-plans, say) is evaluated at the
cost of STAP and the simulator alone. Each episode then reports its recorded and replayed outcome
and where the plan trees part; one whose replay asks a question the recording does not hold has no
answer here (the change reached the language model's decisions: evaluate it with ``t2m eval``), and
makes the script exit 1. ``--calls`` keeps the episodes whose recorded plan holds a call of a skill or
lifted call (``place(hook, table)``): the only ones a change to that call's planning can alter;
``--executed-below V`` those that executed a skill valued below V: the only ones ``run.retry_below=V``
can alter.
The summary gives the recorded and replayed successes of the replayed episodes and of the whole
evaluation with them replaced.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from collections.abc import Sequence
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


def replay_config(directory: Path, work: Path, overrides: Sequence[str] = ()):
    """The episode's recorded configuration with the language model replaced by its transcript, and
    ``overrides`` (``a.b=c``) applied."""
    from t2m_core.config.resolve import resolve_config
    from t2m_core.registry import get_registry

    recorded = yaml.safe_load((directory / "config.yaml").read_text(encoding="utf-8"))
    recorded["language_model"] = {"name": "replay", "options": {"transcript": str((directory / "transcript.jsonl").resolve())}}
    path = work / "config.yaml"
    path.write_text(yaml.safe_dump(recorded, sort_keys=False), encoding="utf-8")
    return resolve_config([path], overrides=overrides, registry=get_registry())


def replay(directory: Path, work: Path, overrides: Sequence[str] = ()) -> dict[str, Any]:
    """Replay one recorded episode into ``work`` (under ``overrides``) and compare it with the recording."""
    from t2m_core.episode import run_episode
    from t2m_core.run_records import read_plan_tree, read_result

    recorded = read_result(directory)
    assert recorded is not None, directory
    work.mkdir(parents=True, exist_ok=True)
    config = replay_config(directory, work, overrides)
    run = work / "run"
    for name in ("plan_tree.jsonl", "transcript.jsonl", "result.json"):  # an interrupted replay starts afresh
        (run / name).unlink(missing_ok=True)
    started = time.perf_counter()
    try:
        result = run_episode(config, run).as_dict()
        error = None
    except Exception as failure:  # noqa: BLE001 - a replay that asks an unrecorded question is a mismatch, reported
        result, error = {}, f"{type(failure).__name__}: {failure}"
    seconds = time.perf_counter() - started
    tree = first_difference(read_plan_tree(directory), read_plan_tree(run)) if error is None else error
    results = [k for k in RESULT_KEYS if recorded.get(k) != result.get(k)] if error is None else list(RESULT_KEYS)
    return {
        "task": recorded["task"], "seed_index": seed_index(directory), "planner": recorded["planner"],
        "success": recorded["success"], "matches": tree is None and not results, "plan_tree_difference": tree,
        "result_differences": results, "recorded_seconds": recorded["timings"]["total"], "replay_seconds": round(seconds, 2),
        "replayed": error is None, "error": error, "replayed_success": result.get("success"),
        "replayed_failure": result.get("failure"), "recorded_failure": recorded.get("failure"),
    }


def holds_call(plan: Sequence[str], entries: set[str]) -> bool:
    """Whether a recorded plan (skill strings) holds a call of a skill or lifted call of ``entries``."""
    from t2m_core.domain.skills import parse_skill_call

    calls = [parse_skill_call(text) for text in plan]
    return any({call.name, call.lifted} & entries for call in calls)


def _replay_item(item: tuple[Path, Path, tuple[str, ...]]) -> dict[str, Any]:
    directory, work, overrides = item
    return replay(directory, work, overrides)


def what_if_summary(rows: list[dict[str, Any]], recorded: list[dict[str, Any]]) -> dict[str, Any]:
    """Successes of the replayed episodes, recorded and replayed, and of the whole evaluation
    (``recorded``: every episode's result) with the replayed episodes' outcomes in place of theirs."""
    replayed = [r for r in rows if r["replayed"]]
    return {
        "episodes_replayed": len(replayed), "not_replayable": len(rows) - len(replayed),
        "recorded_successes": sum(bool(r["success"]) for r in replayed),
        "replayed_successes": sum(bool(r["replayed_success"]) for r in replayed),
        "gained": [f"{r['task']} seed {r['seed_index']}" for r in replayed if r["replayed_success"] and not r["success"]],
        "lost": [f"{r['task']} seed {r['seed_index']}" for r in replayed if r["success"] and not r["replayed_success"]],
        "evaluation_episodes": len(recorded),
        "evaluation_recorded_successes": sum(bool(r["success"]) for r in recorded),
        "evaluation_with_replays": sum(bool(r["success"]) for r in recorded)
        + sum(bool(r["replayed_success"]) - bool(r["success"]) for r in replayed),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("evaluation", type=Path, help="a t2m eval directory")
    parser.add_argument("--json", dest="json_out", required=True)
    parser.add_argument("--tasks", default=None, help="comma-separated task ids (default: all recorded)")
    parser.add_argument("--seeds", default=None, help="seed indices, 0-9 or 0,3,5 (default: all recorded)")
    parser.add_argument("--work", type=Path, default=None, help="where the replays are written (default: a temporary directory)")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                        help="replay under a changed configuration (repeatable): report outcomes instead of matches")
    parser.add_argument("--calls", action="append", default=None, metavar="CALL",
                        help="a skill or lifted call (repeatable): only the episodes whose recorded plan holds one")
    parser.add_argument("--executed-below", type=float, default=None,
                        help="only the episodes that executed a skill valued below this")
    parser.add_argument("--workers", type=int, default=1, help="episodes replayed at once (default 1)")
    args = parser.parse_args()

    from t2m_core.atomic_files import write_json_atomic
    from t2m_core.evaluation import parse_seed_indices
    from t2m_core.executors.local import LocalExecutor
    from t2m_core.run_records import episode_results
    from t2m_stap.options import veto_entry

    tasks = None if args.tasks is None else set(args.tasks.split(","))
    seeds = None if args.seeds is None else set(parse_seed_indices(args.seeds))
    try:
        calls = None if args.calls is None else {veto_entry(entry) for entry in args.calls}
    except ValueError as problem:
        parser.error(f"--calls: {problem}")
    everything = episode_results(args.evaluation)
    episodes = [(d, r) for d, r in everything
                if (tasks is None or r["task"] in tasks) and (seeds is None or seed_index(d) in seeds)
                and (calls is None or holds_call(r.get("plan") or [], calls))
                and (args.executed_below is None or any(step["value"] < args.executed_below for step in r.get("executed") or []))]
    if not episodes:
        raise SystemExit(f"no finished episodes in {args.evaluation} match --tasks/--seeds/--calls/--executed-below")
    what_if = bool(args.overrides)
    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        work = args.work or Path(scratch)
        items = [(d, work / d.relative_to(args.evaluation), tuple(args.overrides)) for d, _ in episodes]
        for _, row in LocalExecutor(args.workers).map(_replay_item, items):
            rows.append(row)
            if what_if:
                verdict = (f"NOT REPLAYABLE: {row['error']}" if not row["replayed"] else
                           f"{_outcome(row['success'], row['recorded_failure'])} -> {_outcome(row['replayed_success'], row['replayed_failure'])}")
            else:
                verdict = "same decisions" if row["matches"] else f"DIFFERS: {row['plan_tree_difference'] or row['result_differences']}"
            print(f"{row['planner']} {row['task']} seed {row['seed_index']}: {verdict} "
                  f"(replay {row['replay_seconds']:.0f} s, recorded {row['recorded_seconds']:.0f} s)", flush=True)
    rows.sort(key=lambda r: (r["planner"], r["task"], r["seed_index"]))
    matched = sum(r["matches"] for r in rows)
    summary = {"episodes": len(rows), "matched": matched, "replay_seconds": round(sum(r["replay_seconds"] for r in rows), 1),
               "recorded_seconds": round(sum(r["recorded_seconds"] for r in rows), 1)}
    report: dict[str, Any] = {"evaluation": str(args.evaluation), "overrides": args.overrides, "calls": sorted(calls or []), "summary": summary}
    if what_if:
        summary.update(what_if_summary(rows, [r for _, r in everything]))
        print(f"under {' '.join(args.overrides)}: {summary['replayed_successes']} of {summary['episodes_replayed']} replayed episodes "
              f"reached the goal against {summary['recorded_successes']} recorded (gained {', '.join(summary['gained']) or 'none'}; "
              f"lost {', '.join(summary['lost']) or 'none'}); the evaluation: {summary['evaluation_with_replays']} of "
              f"{summary['evaluation_episodes']} against {summary['evaluation_recorded_successes']}")
    else:
        print(f"{matched} of {len(rows)} replayed episodes took the recorded decisions "
              f"({summary['replay_seconds']:.0f} s replayed against {summary['recorded_seconds']:.0f} s recorded)")
    write_json_atomic(args.json_out, {**report, "episodes": rows})
    if what_if and summary["not_replayable"]:
        raise SystemExit(f"{summary['not_replayable']} episode(s) asked the language model a question their recording does not hold: "
                         "the change reaches the task planner's decisions; evaluate it with t2m eval")
    if not what_if and matched != len(rows):
        raise SystemExit(1)


def _outcome(success: bool | None, failure: str | None) -> str:
    return "success" if success else f"failed ({failure})"


if __name__ == "__main__":
    main()
