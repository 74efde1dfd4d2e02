"""Cost of skill data against the number of actions executed per reset scene.

    python benchmarks/datagen_speed.py [--skills pick,place,pull,push] [--actions 1,4] [--size 100]
                                       [--sim mujoco] [--json OUT]

For each skill and each ``actions_per_scene`` value it generates one train chunk of ``--size``
transitions in this process (after a warm-up chunk that compiles the scenes' models) and prints
transitions per worker-second, the share of time spent in resets, draws per kept transition and
the success rate before balancing. Every row generates the same chunk indices, so the rows of one
skill differ only by the setting; the ratio to ``actions_per_scene = 1`` is measured in the same run.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from rich.console import Console
from rich.table import Table

CHUNK_INDEX = 90_000
"""Chunk indices of the measurement (far from any dataset's chunks, so nothing is reused)."""


def measure(skill: str, actions: int, size: int, simulator) -> dict:
    """One chunk of ``size`` transitions with ``actions`` actions per scene: speed and what it cost."""
    from t2m_core.data.chunks import ChunkSpec, generate_chunk

    transitions, stats = generate_chunk(ChunkSpec(skill, "train", CHUNK_INDEX, size, actions_per_scene=actions), simulator)
    successes = int(transitions.success.sum())
    executed = stats.draws - stats.reset_failures
    return {
        "skill": skill,
        "actions_per_scene": actions,
        "transitions": len(transitions),
        "seconds": round(stats.seconds, 2),
        "transitions_per_second": round(len(transitions) / stats.seconds, 2),
        "reset_share": round(stats.reset_seconds / stats.seconds, 3),
        "draws_per_transition": round(stats.draws / len(transitions), 2),
        "raw_success_rate": round(successes / executed, 3) if executed else 0.0,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--skills", default="pick,place,pull,push")
    parser.add_argument("--actions", default="1,4", help="comma-separated actions_per_scene values")
    parser.add_argument("--size", type=int, default=100, help="transitions per measured chunk")
    parser.add_argument("--sim", default="mujoco")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args(argv)
    try:
        actions = [int(value) for value in args.actions.split(",")]
    except ValueError:
        parser.error(f"--actions must be comma-separated integers, got {args.actions!r}")
    if min(actions) < 1 or args.size < 1:
        parser.error("--actions values and --size must be >= 1")

    from t2m_core.data.chunks import ChunkSpec, generate_chunk
    from t2m_core.data.scenes import DATA_SKILLS
    from t2m_core.registry import get_registry

    skills = args.skills.split(",")
    unknown = [s for s in skills if s not in DATA_SKILLS]
    if unknown:
        parser.error(f"unknown skills {unknown}; use {', '.join(DATA_SKILLS)}")
    simulator = get_registry().create("simulator", args.sim)
    rows = []
    for skill in skills:
        generate_chunk(ChunkSpec(skill, "train", CHUNK_INDEX + 1, 20), simulator)  # warm-up: compile the scenes
        base = None
        for value in actions:
            row = measure(skill, value, args.size, simulator)
            base = base or row["transitions_per_second"]
            row["speedup"] = round(row["transitions_per_second"] / base, 2)
            rows.append(row)
            print(json.dumps(row), file=sys.stderr)

    table = Table(title=f"Skill data cost ({args.sim}, {args.size} transitions per chunk, one worker)", title_justify="left")
    for column in ("skill", "actions/scene", "transitions/s", "x vs first", "reset share", "draws/transition", "raw success"):
        table.add_column(column, justify="right")
    for r in rows:
        table.add_row(r["skill"], str(r["actions_per_scene"]), f"{r['transitions_per_second']:.1f}", f"{r['speedup']:.2f}",
                      f"{r['reset_share']:.0%}", f"{r['draws_per_transition']:.1f}", f"{r['raw_success_rate']:.0%}")
    Console().print(table)
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps({"simulator": args.sim, "size": args.size, "rows": rows}, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
