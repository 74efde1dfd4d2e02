"""Which objects stand in the way of a hook sweep in a task's scenes, by the domain's geometry.

    python benchmarks/sweep_blockers.py --task task3 --call "pull(blue_box, hook)" --seeds 0-19
        [--draws 4000] [--json OUT]

For every seed: sample the task's initial scene (base seed = index × 1000, as ``t2m eval`` does; the
geometric sampler alone, no physics), draw ``--draws`` actions uniformly over the primitive's whole
range and predict each sweep (:meth:`~t2m_core.domain.primitives.hook_sweep.HookSweep.predict`).
Per bystander (every object but the arguments and the table), the share of draws whose swept hook
or swept box comes within the tool clearance of it; and the share that pass clear of every
bystander. The hand's path is left out: it depends on where the hook will be held, which the
initial scene does not know. A bystander that stands in the way of nearly every draw is one no
choice of action avoids: the rack, which no skill moves, or a box that must be moved first.

This is a prediction from the geometry, not a simulation: ``benchmarks/action_ranking.py`` executes
actions in MuJoCo.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--task", required=True)
    parser.add_argument("--call", required=True, help='a pull or push call, e.g. "pull(blue_box, hook)"')
    parser.add_argument("--seeds", default="0-9", help="seed indices: 0-9 or 0,3,5 (base seed = index x 1000)")
    parser.add_argument("--draws", type=int, default=4000, help="uniform actions per seed")
    parser.add_argument("--json", dest="json_out", default=None)
    args = parser.parse_args()
    if args.draws < 1:
        parser.error("--draws must be at least 1")

    from rich.console import Console
    from rich.table import Table

    from t2m_core.atomic_files import write_json_atomic
    from t2m_core.domain.primitives import get_primitive
    from t2m_core.domain.primitives.sweep_screen import bystanders, obstacle_footprints, sweep_disturbs
    from t2m_core.domain.sampling import sample_task
    from t2m_core.domain.skills import parse_skill_call
    from t2m_core.errors import T2MError
    from t2m_core.evaluation import SEED_SPACING, parse_seed_indices
    from t2m_core.tasks import load_task

    try:
        call = parse_skill_call(args.call)
        if call.name not in ("pull", "push"):
            raise T2MError(f"{args.call!r} is not a hook sweep; give a pull or push call")
        task = load_task(args.task)
        missing = [name for name in call.args if name not in task.objects]
        if missing:
            raise T2MError(f"{task.id} has no object {', '.join(missing)}; its objects: {', '.join(task.objects)}")
        seeds = parse_seed_indices(args.seeds)
    except (T2MError, ValueError) as error:
        sys.exit(f"error: {error}")

    primitive = get_primitive(call.name)
    rng = np.random.default_rng(0)
    rows = []
    for seed in seeds:
        state = sample_task(task, seed * SEED_SPACING).state
        draws = rng.uniform(primitive.action_low, primitive.action_high, (args.draws, len(primitive.action_low)))
        prediction = primitive.predict(state, call.args, draws)
        blocked_by, clear = {}, np.ones(args.draws, dtype=bool)
        for geometry in bystanders(state, call.args):
            obstacles = obstacle_footprints([geometry])
            hit = sweep_disturbs(prediction, hook_obstacles=obstacles, target_obstacles=obstacles, hand_obstacles=obstacles[:0])
            blocked_by[geometry.name] = float(hit.mean())
            clear &= ~hit
        rows.append({"seed": seed, "blocked_by": blocked_by, "clear": float(clear.mean())})

    names = [name for name in task.objects if name in rows[0]["blocked_by"]]
    table = Table(title=f"{task.id}: {call} — share of {args.draws} uniform actions whose sweep meets each bystander")
    table.add_column("seed", justify="right")
    for name in names:
        table.add_column(name, justify="right")
    table.add_column("clear of all", justify="right")
    for row in rows:
        table.add_row(str(row["seed"]), *(f"{row['blocked_by'][name]:.0%}" for name in names), f"{row['clear']:.0%}")
    Console().print(table)
    if args.json_out:
        write_json_atomic(args.json_out, {"task": task.id, "call": str(call), "draws": args.draws, "seeds": rows})



if __name__ == "__main__":
    main()
