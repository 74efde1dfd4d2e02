"""Feasibility planning against the physics: each task's reference skeleton executed closed loop.

    python benchmarks/stap_quality.py --json OUT [--planners policy-cem,policy,random-cem] [--tasks all]
        [--seeds 0-9] [--population N] [--option KEY=VALUE ...] [--checkpoints DIR] [--workers N]
        [--replan-start policy|planned]
        [--skeleton "pick(hook), push(cyan_box, hook, rack)" --tasks ID]

For every planner, task and seed: reset MuJoCo to the task's scene (base seed = index × 1000), plan
the task's reference skeleton, execute it closed loop (re-planning the remaining skills after every
executed one) and record whether every skill succeeded, whether the task's goal holds, the first
plan's predicted p_success and step values (for calibration), and the time per plan. Prints
success per task and overall for each planner, and a reliability table of predicted p_success
against realised success. With ``--skeleton`` (one task) it plans and executes that sequence
instead, another order a task planner may choose, and also prints how often a first plan whose
every step value exceeds ``--tau`` (a task planner would accept it) then failed.
"""

from __future__ import annotations

import argparse
import functools
import time

import numpy as np


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", dest="json_out", required=True)
    parser.add_argument("--planners", default="policy-cem,policy,random-cem")
    parser.add_argument("--tasks", default="all")
    parser.add_argument("--seeds", default="0-9", help="seed indices: 0-9 or 0,3,5 (base seed = index x 1000)")
    parser.add_argument("--population", type=int, default=None, help="override the CEM/shooting population")
    parser.add_argument("--option", action="append", default=[], metavar="KEY=VALUE",
                        help="a feasibility-planner option for every planner but policy (e.g. restarts=3); repeatable")
    parser.add_argument("--sim", default="mujoco")
    parser.add_argument("--checkpoints", default=None, help="skill checkpoints directory (default: the shipped ones)")
    parser.add_argument("--plot", default=None, help="write a reliability plot (PNG) of predicted p_success against success")
    parser.add_argument("--replan-start", choices=("policy", "planned"), default="policy",
                        help="where each closed-loop re-plan starts: from scratch (policy) or from the previous plan's remaining actions")
    parser.add_argument("--skeleton", default=None, help='with one task in --tasks: this skill sequence instead of the reference one')
    parser.add_argument("--tau", type=float, default=0.1, help="the value every step of an accepted first plan exceeds (hybrid's default)")
    parser.add_argument("--workers", type=int, default=1,
                        help="episodes run at once in local worker processes (each plan seeds its own generator, so "
                             "the results do not depend on this)")
    args = parser.parse_args()

    from t2m_core.atomic_files import write_json_atomic
    from t2m_core.errors import T2MError
    from t2m_core.evaluation import parse_seed_indices
    from t2m_core.executors import make_executor
    from t2m_core.tasks import task_ids

    tasks = list(task_ids()) if args.tasks == "all" else args.tasks.split(",")
    try:
        seeds = parse_seed_indices(args.seeds)
    except T2MError as error:
        parser.error(f"{error.message} ({error.hint})")
    planner_names = args.planners.split(",")
    # everything the report at the end needs, imported now: sources edited during a long run do not
    # mix with the modules already loaded
    import t2m_skills_tableenv.report  # noqa: F401

    from t2m_core.config.resolve import parse_override

    options = {}
    for item in args.option:
        try:
            path, value = parse_override(item)
        except T2MError:
            path, value = (), None
        if len(path) != 1:
            parser.error(f"--option {item!r}: give KEY=VALUE, e.g. restarts=3")
        options[path[0]] = value
    if args.population:
        options["population"] = args.population
    if args.skeleton is not None:
        from t2m_core.data.rollouts import rollout_skeleton
        from t2m_core.tasks import load_task

        if len(tasks) != 1:
            parser.error("--skeleton needs exactly one task in --tasks")
        try:
            rollout_skeleton(load_task(tasks[0]), args.skeleton)
        except T2MError as error:
            parser.error(f"--skeleton: {error.message} ({error.hint})")
    jobs = [(planner_name, task_id, seed) for planner_name in planner_names for task_id in tasks for seed in seeds]
    run = functools.partial(_run_episode, sim=args.sim, checkpoints=args.checkpoints, options=options,
                            replan_start=args.replan_start, skeleton=args.skeleton)
    with make_executor("local", workers=args.workers) as pool:
        finished = dict(pool.map(run, jobs))
    if "simulator" in _PROCESS_PARTS:  # one worker: the episodes ran in this process
        _PROCESS_PARTS["simulator"].close()
    report: dict = {"simulator": args.sim, "checkpoints": args.checkpoints or "shipped", "options": options, "replan_start": args.replan_start,
                    "skeleton": args.skeleton, "tau": args.tau, "planners": {}}
    for planner_name in planner_names:
        episodes = [finished[job] for job in jobs if job[0] == planner_name]
        per_task = {t: float(np.mean([e["success"] for e in episodes if e["task"] == t])) for t in tasks}
        overall = float(np.mean([e["success"] for e in episodes]))
        print(f"{planner_name}: overall {overall:.0%} ({sum(e['success'] for e in episodes)} / {len(episodes)}); "
              + ", ".join(f"{t} {v:.0%}" for t, v in per_task.items()))
        accepted = [e for e in episodes if e["first_values"] and min(e["first_values"]) > args.tau]
        acceptance = {"accepted": len(accepted), "accepted_failed": sum(not e["success"] for e in accepted),
                      "rejected_succeeded": sum(e["success"] for e in episodes if e not in accepted)}
        print(f"  first plans with every step value above tau {args.tau}: {acceptance['accepted']} of {len(episodes)}, "
              f"{acceptance['accepted_failed']} of them failed; {acceptance['rejected_succeeded']} rejected ones succeeded")
        report["planners"][planner_name] = {"overall": overall, "per_task": per_task, "episodes": episodes,
                                            "reliability": reliability(episodes), "acceptance": acceptance}
    write_json_atomic(args.json_out, report)
    if args.plot:
        plot_reliability(report, args.plot)


_PROCESS_PARTS: dict = {}
"""This process's simulator, skill library and planners, made by its first episode and kept for the rest."""


def _run_episode(job: tuple[str, str, int], *, sim: str, checkpoints: str | None, options: dict, replan_start: str,
                 skeleton: str | None = None) -> dict:
    """One (planner, task, seed index) episode: reset, plan and execute the reference skeleton (or
    ``skeleton``) closed loop."""
    from t2m_core.closed_loop import execute_closed_loop
    from t2m_core.data.rollouts import rollout_skeleton
    from t2m_core.domain.goals import goal_satisfied_full
    from t2m_core.evaluation import SEED_SPACING
    from t2m_core.registry import get_registry
    from t2m_core.tasks import load_task

    planner_name, task_id, seed = job
    registry = get_registry()
    if "simulator" not in _PROCESS_PARTS:
        _PROCESS_PARTS["simulator"] = registry.create("simulator", sim)
        _PROCESS_PARTS["skills"] = registry.create("skill_library", "tableenv", {"checkpoints": checkpoints} if checkpoints else {})
    if planner_name not in _PROCESS_PARTS:
        _PROCESS_PARTS[planner_name] = registry.create("feasibility_planner", planner_name, options if planner_name != "policy" else {})
    simulator, task = _PROCESS_PARTS["simulator"], load_task(task_id)
    reset = simulator.reset(task, seed=seed * SEED_SPACING)
    started = time.perf_counter()
    calls = task.reference_skeleton if skeleton is None else rollout_skeleton(task, skeleton)
    result = execute_closed_loop(simulator, _PROCESS_PARTS[planner_name], _PROCESS_PARTS["skills"], calls, reset.state.object_names,
                                 replan_start=replan_start)
    elapsed = time.perf_counter() - started
    reached = result.success and bool(goal_satisfied_full(task.goal, simulator.geometric_state(), task.initial_state))
    failure = next((f"{s.call}: {s.result.failure}" for s in result.steps if not s.result.success), None)
    print(f"{planner_name:15s} {task_id} seed {seed}: {'success' if reached else failure or 'goal not reached'}", flush=True)
    return {
        "task": task_id, "seed": seed, "success": reached, "skills_succeeded": sum(s.result.success for s in result.steps),
        "failure": failure,
        "predicted_p_success": float(result.initial_plan.p_success) if result.initial_plan else None,
        "first_values": [round(float(v), 4) for v in result.initial_plan.values] if result.initial_plan else [],
        "seconds_per_plan": elapsed / max(len(result.steps), 1),
    }


def reliability(episodes: list[dict]) -> list[dict]:
    """Predicted p_success of the first plan against realised success, in bins of 0.2."""
    from t2m_skills_tableenv.report import reliability as binned

    planned = [e for e in episodes if e["predicted_p_success"] is not None]
    return binned(np.array([e["predicted_p_success"] for e in planned]), np.array([e["success"] for e in planned], dtype=float),
                  np.linspace(0.0, 1.0, 6))


def plot_reliability(report: dict, path: str) -> None:
    """Realised success against the first plan's predicted p_success, one line per planner."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axis = plt.subplots(figsize=(5, 5))
    axis.plot([0, 1], [0, 1], color="grey", linestyle="--", linewidth=1, label="perfect calibration")
    for planner, entry in report["planners"].items():
        rows = entry["reliability"]
        axis.plot([r["predicted"] for r in rows], [r["realised"] for r in rows], marker="o", label=f"{planner} (overall {entry['overall']:.0%})")
    axis.set_xlabel("predicted p_success of the first plan")
    axis.set_ylabel("realised success (closed loop, MuJoCo)")
    axis.legend(fontsize=8)
    figure.savefig(path, dpi=90, bbox_inches="tight")
    plt.close(figure)


if __name__ == "__main__":
    main()
