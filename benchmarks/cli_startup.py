"""Median wall time of `t2m --help` and `t2m list-plugins` (goal: under 1 s each).

Both commands import every plugin's hooks module, so this measures what a user waits for before the
CLI answers. Each command runs in a fresh process, ``--runs`` times after one warm-up run (which
fills the OS file cache and Python's bytecode cache).

    python benchmarks/cli_startup.py --runs 10 --json out/cli_startup.json
"""

from __future__ import annotations

import argparse
import os
import platform
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

from t2m_core.atomic_files import write_json_atomic

COMMANDS: dict[str, list[str]] = {"t2m --help": ["--help"], "t2m list-plugins": ["list-plugins"]}
GOAL_S = 1.0


def t2m_executable() -> list[str]:
    """The installed console script, or the module run by this interpreter when it is not on PATH."""
    script = shutil.which("t2m") or str(Path(sys.executable).with_name("t2m"))
    return [script] if Path(script).exists() else [sys.executable, "-m", "t2m_core.cli.main"]


def wall_times(command: list[str], runs: int) -> list[float]:
    """Seconds per run of ``command`` (output discarded), after one warm-up run."""
    times = []
    for attempt in range(runs + 1):
        start = time.perf_counter()
        subprocess.run(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
        if attempt:
            times.append(time.perf_counter() - start)
    return times


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=10, help="timed runs per command (default 10)")
    parser.add_argument("--json", type=Path, dest="json_out", help="also write the figures to this JSON file")
    arguments = parser.parse_args()

    executable = t2m_executable()
    results = {}
    for label, extra in COMMANDS.items():
        times = wall_times([*executable, *extra], arguments.runs)
        median = statistics.median(times)
        results[label] = {"median_s": round(median, 4), "min_s": round(min(times), 4), "max_s": round(max(times), 4)}
        verdict = "ok" if median < GOAL_S else f"over the {GOAL_S:.0f} s goal"
        print(
            f"{label:<18} median {median:.3f} s  (min {min(times):.3f}, max {max(times):.3f}, {len(times)} runs)  {verdict}"
        )
    if arguments.json_out:
        write_json_atomic(
            arguments.json_out,
            {
                "benchmark": "cli_startup",
                "runs": arguments.runs,
                "goal_s": GOAL_S,
                "python": platform.python_version(),
                "machine": f"{platform.machine()}, {os.cpu_count()} CPUs",
                "commands": results,
            },
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
