"""Initial-state sampler per task over base seeds 0..N-1: success rate, rejections per accepted scene,
the acceptance rate of single candidate seeds, and milliseconds per sample.

Each base seed is sampled from scratch (the candidate memo is cleared first), so the time is the true
cost of one reset's geometric sampling, rejections included. Physics settling is not part of it.

    python benchmarks/sampler_rejection.py --seeds 100 --json out/sampler_rejection.json
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

from rich.console import Console
from rich.progress import Progress
from rich.table import Table

from t2m_core.atomic_files import write_json_atomic
from t2m_core.domain.sampling import SamplingError, clear_cache, sample_task
from t2m_core.tasks import list_tasks


def measure(seeds: int, max_attempts: int) -> dict[str, dict[str, float]]:
    """Per task id, over base seeds ``0..seeds-1``: ``success_rate, mean_rejections, max_rejections,
    candidate_acceptance`` (fraction of the single candidate seeds 0..seeds-1 that are accepted; the
    base seeds' rejection chains overlap, so this is the unbiased per-candidate rate),
    ``ms_per_sample`` (median) and ``ms_per_sample_mean``."""
    tasks = list_tasks()
    results: dict[str, dict[str, float]] = {}
    with Progress(console=Console(stderr=True), transient=True) as progress:
        bar = progress.add_task("sampling", total=2 * len(tasks) * seeds)
        for task in tasks:
            rejections: list[int] = []
            times: list[float] = []
            for seed in range(seeds):
                clear_cache()
                start = time.perf_counter()
                try:
                    rejections.append(sample_task(task, seed, max_attempts=max_attempts).rejections)
                except SamplingError:
                    pass  # counted by success_rate
                times.append(time.perf_counter() - start)
                progress.advance(bar)
            accepted = len(rejections)
            single = 0
            for candidate in range(seeds):
                try:
                    sample_task(task, candidate, max_attempts=1)
                    single += 1
                except SamplingError:
                    pass
                progress.advance(bar)
            results[task.id] = {
                "success_rate": accepted / seeds,
                "mean_rejections": statistics.fmean(rejections) if rejections else float("nan"),
                "max_rejections": max(rejections, default=0),
                "candidate_acceptance": single / seeds,
                "ms_per_sample": 1000 * statistics.median(times),
                "ms_per_sample_mean": 1000 * statistics.fmean(times),
            }
    return results


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=100, help="base seeds 0..N-1 per task (default 100)")
    parser.add_argument("--max-attempts", type=int, default=1000, help="candidate seeds per sample (default 1000)")
    parser.add_argument("--json", type=Path, dest="json_out", help="also write the figures to this JSON file")
    arguments = parser.parse_args()

    results = measure(arguments.seeds, arguments.max_attempts)
    table = Table(title=f"initial-state sampler, base seeds 0..{arguments.seeds - 1}", title_justify="left")
    for column in ("task", "success", "mean rej.", "max rej.", "p(accept)", "ms (median)", "ms (mean)"):
        table.add_column(column, justify="right")
    for task_id, row in results.items():
        table.add_row(
            task_id,
            f"{row['success_rate']:.0%}",
            f"{row['mean_rejections']:.1f}",
            str(row["max_rejections"]),
            f"{row['candidate_acceptance']:.3f}",
            f"{row['ms_per_sample']:.0f}",
            f"{row['ms_per_sample_mean']:.0f}",
        )
    Console().print(table)
    if arguments.json_out is not None:
        arguments.json_out.parent.mkdir(parents=True, exist_ok=True)
        write_json_atomic(arguments.json_out, {"seeds": arguments.seeds, "tasks": results})
    return 0


if __name__ == "__main__":
    sys.exit(main())
