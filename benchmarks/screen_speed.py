"""Speed of the screened Pull and Push sampler (``screened_physical``) per call, in data-generation scenes.

    python benchmarks/screen_speed.py [--scenes 100] [--repeats 3] [--baseline REV] [--json OUT]

The scenes are skill-data scenes (``draw_data_task(skill, valid=True)``: the hook in hand, distractors
around), fixed by seed; each call gets a generator seeded by its scene's index. Per skill it prints
the mean and median milliseconds per call (the fastest of ``--repeats`` passes over the scenes) and
the fraction of calls whose action passes the screen. With ``--baseline REV`` the same scenes are
also timed on the code of git revision REV, checked out into a temporary worktree and run in a
subprocess, and the speed-up over it is printed.
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

import numpy as np

SKILLS = ("pull", "push")
REPOSITORY = Path(__file__).resolve().parent.parent


def draw_scenes(count: int) -> dict[str, list[dict]]:
    """Per skill, ``count`` data-generation scenes as JSON-ready dicts (state and call arguments)."""
    from t2m_core.data.scenes import draw_data_task
    from t2m_core.domain.sampling import sample_initial_state

    scenes: dict[str, list[dict]] = {}
    for skill in SKILLS:
        rng = np.random.default_rng(2024)
        scenes[skill] = []
        for seed in range(count):
            task = draw_data_task(skill, True, rng)
            state = sample_initial_state(task.objects, task.initial_state, seed).state
            scenes[skill].append(
                {
                    "objects": {n: [*p.position.tolist(), *p.quaternion.tolist()] for n, p in state.objects.items()},
                    "ee_position": state.ee_position.tolist(),
                    "ee_quaternion": state.ee_quaternion.tolist(),
                    "held": state.held,
                    "arguments": list(task.call.args),
                }
            )
    return scenes


def time_calls(scenes: dict[str, list[dict]], repeats: int) -> dict[str, dict[str, float]]:
    """Per skill: ``mean_ms`` and ``median_ms`` per ``screened_physical`` call (fastest pass) and
    ``passing`` (fraction of calls whose action the screen passes), on the importable ``t2m_core``."""
    from t2m_core.domain.primitives import get_primitive
    from t2m_core.domain.state import GeometricState, ObjectPose

    results: dict[str, dict[str, float]] = {}
    for skill, rows in scenes.items():
        primitive = get_primitive(skill)
        states = [
            GeometricState(
                {name: ObjectPose(pose[:3], pose[3:]) for name, pose in row["objects"].items()},
                np.array(row["ee_position"]),
                np.array(row["ee_quaternion"]),
                row["held"],
            )
            for row in rows
        ]
        best: list[float] | None = None
        for _ in range(repeats):
            times, actions = [], []
            for index, (state, row) in enumerate(zip(states, rows, strict=True)):
                rng = np.random.default_rng(index)
                started = time.perf_counter()
                actions.append(primitive.screened_physical(state, row["arguments"], rng))
                times.append(time.perf_counter() - started)
            best = times if best is None or sum(times) < sum(best) else best
        passing = [
            primitive.screen(s, r["arguments"], a) is None for s, r, a in zip(states, rows, actions, strict=True)
        ]
        results[skill] = {
            "mean_ms": 1e3 * statistics.fmean(best),
            "median_ms": 1e3 * statistics.median(best),
            "passing": float(np.mean(passing)),
        }
    return results


def time_baseline(revision: str, scenes_file: Path, repeats: int) -> dict[str, dict[str, float]]:
    """:func:`time_calls` on the code of ``revision``, in a subprocess run from a temporary worktree."""
    with tempfile.TemporaryDirectory() as parent:
        worktree = Path(parent) / "baseline"
        subprocess.run(
            ["git", "-C", str(REPOSITORY), "worktree", "add", "--detach", str(worktree), revision], check=True
        )
        try:
            command = [sys.executable, __file__, "--time-scenes", str(scenes_file), "--repeats", str(repeats)]
            environment = {**os.environ, "PYTHONPATH": str(worktree)}  # its t2m_core ahead of the installed one
            output = subprocess.run(command, cwd=worktree, env=environment, check=True, capture_output=True, text=True)
        finally:
            subprocess.run(["git", "-C", str(REPOSITORY), "worktree", "remove", "--force", str(worktree)], check=True)
    return json.loads(output.stdout)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=100, help="scenes per skill")
    parser.add_argument("--repeats", type=int, default=3, help="passes over the scenes; the fastest counts")
    parser.add_argument("--baseline", metavar="REV", help="also time the code of this git revision")
    parser.add_argument("--json", metavar="OUT", help="also write the figures to this JSON file")
    parser.add_argument("--time-scenes", metavar="FILE", help=argparse.SUPPRESS)  # the baseline's subprocess
    args = parser.parse_args()
    if args.time_scenes:
        print(json.dumps(time_calls(json.loads(Path(args.time_scenes).read_text()), args.repeats)))
        return

    scenes = draw_scenes(args.scenes)
    figures: dict[str, object] = {"scenes_per_skill": args.scenes, "current": time_calls(scenes, args.repeats)}
    if args.baseline:
        with tempfile.TemporaryDirectory() as folder:
            scenes_file = Path(folder) / "scenes.json"
            scenes_file.write_text(json.dumps(scenes))
            figures["baseline"] = {"revision": args.baseline, **time_baseline(args.baseline, scenes_file, args.repeats)}
    for skill in SKILLS:
        current = figures["current"][skill]
        line = f"{skill:5s} current {current['mean_ms']:8.2f} ms/call (median {current['median_ms']:.2f}, passing {current['passing']:.2f})"
        if args.baseline:
            baseline = figures["baseline"][skill]
            figures[f"{skill}_speedup"] = speedup = baseline["mean_ms"] / current["mean_ms"]
            line += (
                f"   baseline {baseline['mean_ms']:8.2f} ms/call (median {baseline['median_ms']:.2f},"
                f" passing {baseline['passing']:.2f})   speed-up {speedup:.1f}x"
            )
        print(line)
    if args.json:
        from t2m_core.atomic_files import write_json_atomic

        write_json_atomic(args.json, figures)


if __name__ == "__main__":
    main()
