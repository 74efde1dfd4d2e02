"""Throughput of the local and the Ray executor on this machine for the same jobs, Ray's overhead
per task, and how each scales from 1 to 2 workers (docs/guide/scaling.md#throughput).

    python benchmarks/executor_throughput.py --json out/executor_throughput.json [--workers 1,2]
        [--transitions 200] [--chunk-size 25] [--episodes 24] [--tasks 40] [--repeats 2]

Three jobs, each run by ``local`` and ``ray`` with every worker count (Ray on a private instance of
this machine with that many CPUs, started before the clock runs; its start is reported apart). The
configurations run in turn, ``--repeats`` rounds; a figure is the best round's (the machine is
shared, and other jobs only ever slow a run down), with every round's value beside it.

1. **datagen**: Pick, train split, MuJoCo, the screened sampler: ``--transitions`` in chunks of
   ``--chunk-size`` (transitions per wall second). Each configuration writes into a fresh directory,
   so worker processes and their simulators start inside the measured time, for both executors.
2. **eval**: a grid of ``--episodes`` hybrid episodes on task0 with the test doubles of
   ``tests/executors/cluster_doubles.py`` (scripted simulator, rule language model, symbolic
   feasibility): the real planner, scene sampling and run records without the model costs, so an
   episode lasts a fraction of a second and the executor's own cost shows (episodes per hour). A
   real episode (language model, STAP, physics) lasts minutes, beside which that cost vanishes.
3. **no-op**: ``--tasks`` tasks that return at once: the cost of a task itself (Ray's overhead per
   task, against the local pool's; with one worker the local executor runs tasks in its own
   process, so its figure is a bare function call).

Wall times include other jobs' load (the load average is recorded).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

from t2m_core.atomic_files import write_json_atomic
from t2m_core.data.generate import DatasetJob, generate_dataset
from t2m_core.evaluation import grid, run_grid
from t2m_core.executors import make_executor

ROOT = Path(__file__).resolve().parents[1]
DOUBLES = "tests.executors.cluster_doubles"


def find_the_doubles() -> None:
    """Let this process and every worker (forked, or Ray's, which inherit the environment) load the
    doubles; called before anything builds the plugin registry."""
    os.environ["T2M_PLUGINS"] = DOUBLES
    os.environ["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))
    sys.path.insert(0, str(ROOT))


def no_op(item: int) -> int:
    return item


def datagen(executor, out: Path, transitions: int, chunk_size: int) -> dict:
    from t2m_core.data import generate

    generate._WORKER_SIMULATORS.clear()  # a forked worker would inherit this process's simulator: each run starts its own
    started = time.perf_counter()
    manifest = generate_dataset(DatasetJob(out, "pick", "train", transitions, chunk_size, 0, "screened", "mujoco"), executor=executor)
    seconds = time.perf_counter() - started
    # busy workers: the chunks' summed seconds over the wall time, how many workers the executor kept busy
    return {"seconds": round(seconds, 2), "transitions": manifest["count"], "transitions_per_second": round(manifest["count"] / seconds, 2),
            "busy_workers": round(manifest["worker_seconds"] / seconds, 2), "shard_sha256": [s["sha256"] for s in manifest["shards"]]}


def evaluation(executor, out: Path, episodes: int) -> dict:
    from tests.executors.cluster_doubles import SELECTION

    started = time.perf_counter()
    results = run_grid(grid(["hybrid"], ["task0"], list(range(episodes))), out, SELECTION[1::2], executor=executor)
    seconds = time.perf_counter() - started
    return {"seconds": round(seconds, 2), "episodes": len(results), "episodes_per_hour": round(3600 * len(results) / seconds)}


def round_trip(executor, tasks: int) -> dict:
    list(executor.map(no_op, [0]))  # the worker process starts outside the clock
    started = time.perf_counter()
    assert len(list(executor.map(no_op, list(range(tasks))))) == tasks
    seconds = time.perf_counter() - started
    return {"tasks": tasks, "ms_per_task": round(1000 * seconds / tasks, 2)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=Path, required=True)
    parser.add_argument("--workers", default="1,2")
    parser.add_argument("--transitions", type=int, default=200)
    parser.add_argument("--chunk-size", type=int, default=25)
    parser.add_argument("--episodes", type=int, default=24)
    parser.add_argument("--tasks", type=int, default=40)
    parser.add_argument("--repeats", type=int, default=2)
    arguments = parser.parse_args()
    find_the_doubles()
    report: dict = {"machine": {"cpus": os.cpu_count(), "load_average_at_start": [round(x, 2) for x in os.getloadavg()]},
                    "jobs": {"datagen": f"pick train MuJoCo screened, {arguments.transitions} transitions in chunks of {arguments.chunk_size}",
                             "eval": f"{arguments.episodes} hybrid task0 episodes on the test doubles",
                             "no_op": f"{arguments.tasks} empty tasks"},
                    "runs": []}
    configurations = [(name, int(w)) for name in ("local", "ray") for w in arguments.workers.split(",")]
    rounds: dict[tuple[str, int], list[dict]] = {c: [] for c in configurations}
    with tempfile.TemporaryDirectory(prefix="t2m-executors-") as scratch:
        for repeat in range(arguments.repeats):
            for name, workers in configurations:
                started = time.perf_counter()
                with make_executor(name, workers=workers) as executor:
                    run = {"startup_seconds": round(time.perf_counter() - started, 2)}
                    place = Path(scratch) / f"{name}-{workers}-{repeat}"
                    run["datagen"] = datagen(executor, place / "data", arguments.transitions, arguments.chunk_size)
                    run["eval"] = evaluation(executor, place / "eval", arguments.episodes)
                    run["no_op"] = round_trip(executor, arguments.tasks)
                print(f"round {repeat}: {name:5s} {workers} worker(s): start {run['startup_seconds']:5.1f} s, datagen "
                      f"{run['datagen']['transitions_per_second']:6.1f} transitions/s ({run['datagen']['busy_workers']:.2f} busy), eval {run['eval']['episodes_per_hour']:6d} episodes/h, "
                      f"{run['no_op']['ms_per_task']:.2f} ms per empty task", flush=True)
                rounds[(name, workers)].append(run)
    digests = {tuple(run["datagen"].pop("shard_sha256")) for runs in rounds.values() for run in runs}
    for (name, workers), runs in rounds.items():
        report["runs"].append({
            "executor": name,
            "workers": workers,
            "startup_seconds": min(r["startup_seconds"] for r in runs),
            "transitions_per_second": max(r["datagen"]["transitions_per_second"] for r in runs),
            "busy_workers": max(r["datagen"]["busy_workers"] for r in runs),
            "episodes_per_hour": max(r["eval"]["episodes_per_hour"] for r in runs),
            "ms_per_empty_task": min(r["no_op"]["ms_per_task"] for r in runs),
            "rounds": runs,
        })
    report["shards_identical_across_runs"] = len(digests) == 1
    report["machine"]["load_average_at_end"] = [round(x, 2) for x in os.getloadavg()]
    by = {(r["executor"], r["workers"]): r for r in report["runs"]}
    scaling = {}
    for name in ("local", "ray"):
        if (name, 1) in by and (name, 2) in by:
            scaling[name] = {key: round(by[(name, 2)][key] / by[(name, 1)][key], 2) for key in ("transitions_per_second", "episodes_per_hour")}
    report["speedup_1_to_2_workers"] = scaling
    report["ray_overhead_ms_per_task"] = {  # against the local executor with as many workers
        workers: round(by[("ray", workers)]["ms_per_empty_task"] - by[("local", workers)]["ms_per_empty_task"], 2)
        for name, workers in by if name == "ray" and ("local", workers) in by
    }
    for run in report["runs"]:
        print(f"best: {run['executor']:5s} {run['workers']} worker(s): {run['transitions_per_second']:6.1f} transitions/s "
              f"({run['busy_workers']:.2f} busy), "
              f"{run['episodes_per_hour']:6d} episodes/h, {run['ms_per_empty_task']:.2f} ms per empty task, start {run['startup_seconds']:.1f} s")
    print(f"speedup 1 -> 2 workers: {scaling}; Ray's overhead per task (ms, by workers): {report['ray_overhead_ms_per_task']}; "
          f"shards identical across all runs: {report['shards_identical_across_runs']}")
    write_json_atomic(arguments.json, report)


if __name__ == "__main__":
    main()
