"""The evaluation grid behind ``t2m eval`` (docs/guide/planners.md#evaluating-planners).

One episode per (planner, task, seed), each in its own run directory ``OUT/<planner>/<task>/seed<N>``.
The grid is resumable: an episode whose ``result.json`` records its end (a success or a failure type)
is kept; any other (killed, interrupted, stopped by an error) is run again. A kept episode must have
been run with the configuration the grid asks for (:func:`config_conflicts`), so that one table
never mixes two configurations. Episodes are the tasks of an executor (local worker processes or a
Ray cluster, :mod:`t2m_core.executors`), each writing its own run directory. Base seeds are spaced
:data:`SEED_SPACING` apart so that no two episodes of a task share an accepted scene (a reset walks
from its base seed to the first accepted candidate).
"""

from __future__ import annotations

import csv
import functools
import io
from collections import defaultdict
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from t2m_core.atomic_files import write_bytes_atomic, write_json_atomic, write_text_atomic
from t2m_core.errors import T2MError
from t2m_core.executors import Executor, LocalExecutor, TaskCounts
from t2m_core.run_records import read_result

SEED_SPACING = 1000
"""Base seed of seed index s: s × 1000, the width of a reset's first window of candidates (t2m_core.domain.sampling.candidate_windows)."""
PAPER_SUCCESS = {"hybrid": 0.82, "best prior language planner": 0.13}
"""The paper's overall success rates on the suite (Text2Motion; the best earlier language planner)."""


@dataclass(frozen=True)
class Episode:
    """One cell of the grid."""

    planner: str
    task: str
    seed_index: int

    @property
    def seed(self) -> int:
        return self.seed_index * SEED_SPACING

    def directory(self, out: Path) -> Path:
        return out / self.planner / self.task / f"seed{self.seed_index}"


def parse_seed_indices(text: str) -> list[int]:
    """Seed indices from ``"0-9"`` (a range, both ends included) or ``"0,3,5"`` (a list).

    Raises:
        T2MError: unreadable text, no seed, or a negative one.
    """
    try:
        if "-" in text:
            low, high = (int(x) for x in text.split("-"))
            values = list(range(low, high + 1))
        else:
            values = [int(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise T2MError(f"cannot read --seeds {text!r}", "write a range like 0-9 or a list like 0,3,5") from None
    if not values or min(values) < 0:
        raise T2MError(f"--seeds {text!r} names no seed or a negative one", "seed indices start at 0")
    return values


def grid(planners: Sequence[str], tasks: Sequence[str], seeds: Sequence[int]) -> list[Episode]:
    """Every episode, planner-major."""
    return [Episode(p, t, s) for p in planners for t in tasks for s in seeds]


def finished(episode: Episode, out: Path) -> dict[str, Any] | None:
    """The episode's result if it ran to its end (it succeeded or has a failure type), else ``None``:
    also for a torn ``result.json``, an interrupted episode and one stopped by an error (a record
    without ``error`` but with neither success nor failure type was written by such an episode before
    the field existed)."""
    try:
        result = read_result(episode.directory(out))
    except T2MError:
        return None
    if result is None or result.get("interrupted") or result.get("error"):
        return None
    return result if result.get("success") or result.get("failure_type") else None


def config_conflicts(recorded: Mapping[str, Any], requested: Mapping[str, Any], prefix: str = "") -> list[str]:
    """``key: recorded -> requested`` for every configuration value that differs between a finished
    episode's ``config.yaml`` and the configuration the grid resolves for it. Keys the record lacks
    (options added since it ran) are not compared."""
    conflicts = []
    for key, value in requested.items():
        if key not in recorded:
            continue
        path = f"{prefix}{key}"
        if isinstance(value, Mapping) and isinstance(recorded[key], Mapping):
            conflicts += config_conflicts(recorded[key], value, path + ".")
        elif recorded[key] != value:
            conflicts.append(f"{path}: {recorded[key]!r} -> {value!r}")
    return conflicts


def check_finished_configs(episodes: Sequence[Episode], out: Path, base_overrides: Sequence[str]) -> None:
    """Refuse to resume ``out`` when a finished episode ran with another configuration.

    Raises:
        ConfigError: naming each such run directory and the values that differ.
    """
    import yaml

    from t2m_core.config.resolve import resolve_config
    from t2m_core.errors import ConfigError
    from t2m_core.registry import get_registry

    problems = []
    for episode in episodes:
        path = episode.directory(out) / "config.yaml"
        try:
            recorded = yaml.safe_load(path.read_text(encoding="utf-8"))
        except (OSError, yaml.YAMLError):
            continue  # no readable record: nothing to compare
        if not isinstance(recorded, dict):
            continue
        config = resolve_config(flags=_flags(episode), overrides=base_overrides, registry=get_registry())
        conflicts = config_conflicts(recorded, config.model_dump(mode="json"))
        if conflicts:
            problems.append(f"  {episode.directory(out)}: " + "; ".join(conflicts))
    if problems:
        shown = problems[:5] + ([f"  ... and {len(problems) - 5} more"] if len(problems) > 5 else [])
        raise ConfigError(
            f"{len(problems)} finished episode{'s' if len(problems) > 1 else ''} in {out} ran with another configuration "
            f"than this evaluation asks for:\n" + "\n".join(shown),
            hint="evaluate into another --out directory, or delete those run directories to run them again",
        )


def _flags(episode: Episode) -> dict[str, Any]:
    return {"planner": episode.planner, "task": episode.task, "seed": episode.seed}


def run_grid(
    episodes: Sequence[Episode],
    out: Path,
    base_overrides: Sequence[str],
    *,
    workers: int = 1,
    executor: Executor | None = None,
    on_result: Callable[[Episode, dict[str, Any]], None] | None = None,
    on_status: Callable[[TaskCounts], None] | None = None,
) -> dict[Episode, dict[str, Any]]:
    """Run every unfinished episode; return every episode's result.

    Args:
        episodes: the grid.
        out: the evaluation directory; the executor's workers must see it.
        base_overrides: ``--set`` overrides for every episode.
        workers: local worker processes, when no ``executor`` is given.
        executor: where the episode tasks run.
        on_result: called with each episode that finishes.
        on_status: called when the tasks' counts change.
    """
    out = Path(out).resolve()  # a worker's working directory is not the driver's
    executor = executor or LocalExecutor(workers)
    results = {e: r for e in episodes if (r := finished(e, out)) is not None}
    check_finished_configs(list(results), out, base_overrides)
    pending = [e for e in episodes if e not in results]
    if pending:
        out.mkdir(parents=True, exist_ok=True)
        executor.require_shared(out)
    for episode, result in executor.map(functools.partial(_run_one, out=out, overrides=list(base_overrides)), pending, on_status=on_status):
        results[episode] = result
        if on_result:
            on_result(episode, result)
    return results


def _run_one(episode: Episode, *, out: Path, overrides: list[str]) -> dict[str, Any]:
    """The task of one episode, run by a worker: the episode writes its own run directory."""
    from t2m_core.config.resolve import resolve_config
    from t2m_core.episode import run_episode
    from t2m_core.registry import get_registry

    config = resolve_config(flags=_flags(episode), overrides=overrides, registry=get_registry())
    directory = episode.directory(out)
    if directory.exists():  # an interrupted attempt: start its records afresh
        for name in ("plan_tree.jsonl", "transcript.jsonl"):
            (directory / name).unlink(missing_ok=True)
    return run_episode(config, directory).as_dict()


# --------------------------------------------------------------------------------------------------
# The results table
# --------------------------------------------------------------------------------------------------

COLUMNS = ("planner", "task", "episodes", "success", "planning_failures", "execution_failures", "subgoal_completion",
           "llm_calls", "seconds_median", "seconds_p90", "llm_seconds", "stap_seconds", "simulation_seconds")


def summarise(results: dict[Episode, dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per (planner, task) and one ``all`` row per planner."""
    import numpy as np

    groups: dict[tuple[str, str], list[dict[str, Any]]] = defaultdict(list)
    for episode, result in results.items():
        groups[(episode.planner, episode.task)].append(result)
        groups[(episode.planner, "all")].append(result)
    rows = []
    for (planner, task), items in sorted(groups.items(), key=lambda kv: (kv[0][0], kv[0][1] == "all", kv[0][1])):
        seconds = np.array([r["timings"]["total"] for r in items])
        rows.append({
            "planner": planner,
            "task": task,
            "episodes": len(items),
            "success": round(float(np.mean([r["success"] for r in items])), 3),
            "planning_failures": sum(r["failure_type"] == "planning_failure" for r in items),
            "execution_failures": sum(r["failure_type"] == "execution_failure" for r in items),
            "subgoal_completion": round(float(np.mean([r["subgoal_completion"] for r in items])), 3),
            "llm_calls": round(float(np.mean([r["llm_calls"] for r in items])), 1),
            "seconds_median": round(float(np.median(seconds)), 1),
            "seconds_p90": round(float(np.percentile(seconds, 90)), 1),
            "llm_seconds": round(float(np.median([r["timings"]["language_model"] for r in items])), 1),
            "stap_seconds": round(float(np.median([r["timings"]["feasibility"] for r in items])), 1),
            "simulation_seconds": round(float(np.median([r["timings"]["simulation"] for r in items])), 1),
        })
    return rows


EPISODE_COLUMNS = ("planner", "task", "seed_index", "success", "failure_type", "failure", "plan", "llm_calls", "stap_calls",
                   "subgoal_completion", "seconds", "llm_seconds", "stap_seconds", "simulation_seconds")


def episode_rows(results: dict[Episode, dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per episode (:data:`EPISODE_COLUMNS`), in grid order: what the summary rows are made of,
    kept so that two evaluations can be compared episode by episode without their run directories."""
    rows = []
    for episode, result in sorted(results.items(), key=lambda kv: (kv[0].planner, kv[0].task, kv[0].seed_index)):
        timings = result["timings"]
        rows.append({
            "planner": episode.planner, "task": episode.task, "seed_index": episode.seed_index, "success": bool(result["success"]),
            "failure_type": result["failure_type"], "failure": result.get("failure"), "plan": "; ".join(result.get("plan") or []),
            "llm_calls": result["llm_calls"], "stap_calls": result.get("stap_calls"), "subgoal_completion": result["subgoal_completion"],
            "seconds": round(timings["total"], 1), "llm_seconds": round(timings["language_model"], 1),
            "stap_seconds": round(timings["feasibility"], 1), "simulation_seconds": round(timings["simulation"], 1),
        })
    return rows


def write_tables(rows: list[dict[str, Any]], out: Path, executor: dict[str, Any] | None = None,
                 episodes: list[dict[str, Any]] | None = None) -> None:
    """``results.json``, ``results.csv``, ``results.md`` and ``success.png`` in ``out``, and with
    ``episodes`` (:func:`episode_rows`) ``episodes.csv``; ``results.json`` also records ``executor``,
    the executor of the run that wrote the tables."""
    write_json_atomic(out / "results.json", {"rows": rows, "paper": PAPER_SUCCESS, "executor": executor})
    write_text_atomic(out / "results.csv", _csv(rows, COLUMNS))
    if episodes is not None:
        write_text_atomic(out / "episodes.csv", _csv(episodes, EPISODE_COLUMNS))
    lines = ["| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    lines += ["| " + " | ".join(str(row[c]) for c in COLUMNS) + " |" for row in rows]
    lines.append("")
    lines.append(f"Paper (overall success): Text2Motion {PAPER_SUCCESS['hybrid']:.0%}, best prior language planner "
                 f"{PAPER_SUCCESS['best prior language planner']:.0%}.")
    write_text_atomic(out / "results.md", "\n".join(lines) + "\n")
    _plot(rows, out / "success.png")


def _csv(rows: list[dict[str, Any]], columns: Sequence[str]) -> str:
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=columns)
    writer.writeheader()
    writer.writerows(rows)
    return buffer.getvalue()


def _plot(rows: list[dict[str, Any]], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    planners = sorted({r["planner"] for r in rows})
    tasks = [t for t in dict.fromkeys(r["task"] for r in rows) if t != "all"] + ["all"]
    value = {(r["planner"], r["task"]): r["success"] for r in rows}
    figure, axis = plt.subplots(figsize=(1.2 * len(tasks) + 3, 4))
    width = 0.8 / max(len(planners), 1)
    for i, planner in enumerate(planners):
        axis.bar(np.arange(len(tasks)) + i * width, [value.get((planner, t), 0.0) for t in tasks], width, label=planner)
    axis.axhline(PAPER_SUCCESS["hybrid"], color="black", linestyle="--", linewidth=1, label="paper: Text2Motion 82 %")
    axis.axhline(PAPER_SUCCESS["best prior language planner"], color="grey", linestyle=":", linewidth=1, label="paper: best prior 13 %")
    axis.set_xticks(np.arange(len(tasks)) + 0.4 - width / 2, tasks)
    axis.set_ylabel("success rate")
    axis.set_ylim(0, 1.05)
    axis.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1, 1))
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=90, bbox_inches="tight")
    plt.close(figure)
    write_bytes_atomic(path, buffer.getvalue())
