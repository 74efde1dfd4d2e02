"""Primitive executions per CPU-second, per primitive, with heuristic actions, and the ratio of their
cost to raw ``mj_step`` replaying the same physics.

    python benchmarks/sim_throughput.py --sim mujoco --json OUT [--samples 40] [--only pull,push] [--set substeps=8]

Each sample resets a task scene, brings it to the primitive's precondition (pick: nothing; place,
pull, push: the object or hook picked first, not timed) and takes a snapshot. Then:

1. **Timed execution.** One heuristic execution from the snapshot, timed with ``time.process_time``
   (CPU seconds of this process: the figure to judge, since the machine is shared) and
   ``time.perf_counter`` (wall seconds, also reported but distorted by other jobs).
2. **Recorded execution.** The snapshot is restored and the same execution runs again while every
   tick's physics inputs are recorded: the actuator targets (``ctrl``), the applied joint forces
   (``qfrc_applied``, the sweep impedance), the weld activations, and the model parameters the
   controller changes (servo gains during a sweep, the held object's gravity compensation, the weld
   pose). The simulator is deterministic, so both runs follow the same trajectory (checked).
3. **Raw reference.** The snapshot is restored once more and the recorded inputs are replayed with
   nothing but assignments and ``mj_step(model, data, nstep=substeps)`` per tick, timed the same
   way. The replay must reproduce the execution's final ``qpos`` bit for bit (``replay_exact``), so
   the reference simulates exactly the contacts, wake-ups and solver work of the primitive, not a
   scene that may have fallen asleep.

The JSON holds, per primitive: ``executions_per_cpu_second``, ``executions_per_second`` (wall),
``raw_executions_per_cpu_second`` (the bound mj_step alone allows), ``ratio_to_raw_mj_step`` (CPU),
``ratio_to_raw_mj_step_wall``, ``mean_ticks``, ``heuristic_success_rate``, ``failures`` and
``replay_exact``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from t2m_core.atomic_files import write_json_atomic

HANDLE_TAIL_GRASP = (-0.1, -0.09, 0.0, 0.0)
"""Physical Pick action on the hook for a Pull: the handle 0.1 m behind the hook's centre, yaw 0. A
box beyond reach is pulled with the head behind it; a grasp near the head would put the EE past the
box, beyond the Panda's 0.73 m reach at the lift height."""

HANDLE_CENTRE_GRASP = (0.0, -0.09, 0.0, 0.0)
"""Physical Pick action on the hook for a Push: the handle at the hook's centre. A Push reaches
0.2-0.4 m behind a box in the operational zone: a grasp on the tail would put the EE within 0.2 m of
the base, where the arm cannot reach the table, and one near the head pushes the hand under the
rack's top plate (measured: 28 % heuristic successes at the centre, 12 % at 0.1 m ahead of it). Choosing the grasp a primitive can use
mirrors the feasible-instance evaluation scenes (docs/guide/skills.md#evaluation-scenes)."""

CASES = {  # primitive -> (task, objects kept or None, setup skills with a physical action or None, measured call)
    "pick": ("task0", None, [], ("pick", ("yellow_box",))),
    "place": ("task0", None, [("pick", ("yellow_box",), None)], ("place", ("yellow_box", "rack"))),
    # task3 without the other two boxes beyond reach (they sit next to the pulled one)
    "pull": ("task3", ("table", "rack", "hook", "red_box", "blue_box"), [("pick", ("hook",), HANDLE_TAIL_GRASP)],
             ("pull", ("blue_box", "hook"))),
    # task1 without the yellow and blue boxes, which the task places in front of the rack to block the push
    "push": ("task1", ("table", "rack", "hook", "cyan_box"), [("pick", ("hook",), HANDLE_CENTRE_GRASP)],
             ("push", ("cyan_box", "hook", "rack"))),
}


PULL_EVALUATION_STATE = (
    "free(hook)", "free(blue_box)", "aligned(rack)", "poslimit(rack)", "inworkspace(rack)", "inworkspace(hook)",
    "beyondworkspace(blue_box)", "nonblocking(blue_box, rack)",
    "on(rack, table)", "on(hook, table)", "on(blue_box, table)",
)
"""The Pull evaluation scene (docs/guide/skills.md#evaluation-scenes): the box beyond the workspace and not blocked by the
rack, the hook free in the workspace. (The Push case above already is its evaluation scene: task1's
propositions about the cyan box, which is in the operational zone, in front of the rack and
nonblocking.)"""

EVALUATION_CASES = {
    "pull": (("table", "rack", "hook", "blue_box"), PULL_EVALUATION_STATE, CASES["pull"][2], CASES["pull"][3]),
}


def evaluation_scene(objects: tuple[str, ...], propositions: tuple[str, ...]):
    """A single-skill scene with the given objects and initial state."""
    from types import SimpleNamespace

    from t2m_core.domain.propositions import Proposition

    state = tuple(Proposition.parse(text) for text in propositions)
    return SimpleNamespace(id=f"eval[{','.join(objects)}]", objects=objects, initial_state=state)


def case_scene(task_id: str, keep: tuple[str, ...] | None):
    """The task, or the task restricted to the objects ``keep`` (propositions about the others dropped)."""
    from types import SimpleNamespace

    from t2m_core.tasks import load_task

    task = load_task(task_id)
    if keep is None:
        return task
    kept = tuple(p for p in task.initial_state if all(arg in keep for arg in p.args))
    return SimpleNamespace(id=f"{task_id}[{','.join(keep)}]", objects=tuple(o for o in task.objects if o in keep), initial_state=kept)


def distinct_scenes(sim, task, count: int):
    """Reset ``count`` times, each from the seed after the previously accepted one, so every sample is
    a different scene (consecutive seeds often resolve to the same accepted seed)."""
    seed = 0
    for _ in range(count):
        reset = sim.reset(task, seed=seed)
        seed = reset.accepted_seed + 1
        yield reset


def prepare(sim, setup, rng) -> bool:
    """Run the setup skills (heuristic or the given physical action first, then the exploration
    sampler); False when one of them does not succeed in 20 tries."""
    from t2m_core.domain.primitives import get_primitive

    for skill, skill_args, physical in setup:
        spec = get_primitive(skill)
        for attempt in range(20):
            snapshot = sim.get_state()
            state = sim.geometric_state()
            if attempt == 0:
                action = spec.heuristic_action(state, skill_args, rng) if physical is None else spec.to_normalized(np.array(physical))
            else:
                action = spec.exploration_action(state, skill_args, rng)
            if sim.execute(skill, skill_args, np.clip(action, -1, 1)).success:
                break
            sim.set_state(snapshot)
        else:
            return False
    return True


class TickRecorder:
    """Records the physics inputs of every tick a :class:`~t2m_mujoco.world.World` simulates, by
    wrapping its ``tick`` method for the duration of a ``with`` block."""

    MODEL_FIELDS = ("actuator_gainprm", "actuator_biasprm", "body_gravcomp", "eq_data")
    """Model parameters the controller changes at run time (servo gains, held load, weld pose)."""

    def __init__(self, world) -> None:
        self.world = world
        self.ticks: list[tuple] = []

    def __enter__(self) -> TickRecorder:
        world = self.world
        original = world.tick

        def recording_tick(count: int = 1) -> None:
            data, model = world.data, world.model
            inputs = (data.ctrl.copy(), data.qfrc_applied.copy(), data.eq_active.copy(),
                      tuple(getattr(model, name).copy() for name in self.MODEL_FIELDS))
            self.ticks.extend([inputs] * count)
            original(count)

        world.tick = recording_tick
        return self

    def __exit__(self, *exc) -> None:
        del self.world.tick  # back to the class's method

    def replay(self) -> tuple[float, float, np.ndarray]:
        """Step the recorded inputs with bare ``mj_step`` from the world's current state; returns
        ``(CPU seconds, wall seconds, final qpos)``. Model parameters are assigned only when they
        change, so the loop is the physics and little else."""
        import mujoco

        world = self.world
        model, data, substeps = world.model, world.data, world.substeps
        saved = tuple(getattr(model, name).copy() for name in self.MODEL_FIELDS)
        plan, previous = [], None
        for ctrl, force, active, parameters in self.ticks:
            changed = None if previous is not None and all(np.array_equal(a, b) for a, b in zip(parameters, previous, strict=True)) else parameters
            plan.append((ctrl, force, active, changed))
            previous = parameters
        cpu, wall = time.process_time(), time.perf_counter()
        for ctrl, force, active, changed in plan:
            data.ctrl[:] = ctrl
            data.qfrc_applied[:] = force
            data.eq_active[:] = active
            if changed is not None:
                for name, value in zip(self.MODEL_FIELDS, changed, strict=True):
                    getattr(model, name)[:] = value
            mujoco.mj_step(model, data, nstep=substeps)
        cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
        for name, value in zip(self.MODEL_FIELDS, saved, strict=True):
            getattr(model, name)[:] = value
        return cpu, wall, data.qpos.copy()


def measure(sim, primitive: str, arguments, action) -> dict:
    """Time one execution from the current state, then its raw ``mj_step`` replay (module docstring)."""
    world = sim.world
    snapshot = world.snapshot()
    cpu, wall, start_ticks = time.process_time(), time.perf_counter(), world.ticks
    result = sim.execute(primitive, arguments, action)
    cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
    ticks = world.ticks - start_ticks
    final_qpos = world.data.qpos.copy()

    world.restore(snapshot)
    with TickRecorder(world) as recorder:
        again = sim.execute(primitive, arguments, action)
    if again.failure != result.failure or not np.array_equal(world.data.qpos, final_qpos):
        raise RuntimeError(f"{primitive}: a repeated execution from the same snapshot diverged (determinism broken)")
    world.restore(snapshot)
    raw_cpu, raw_wall, replayed_qpos = recorder.replay()
    world.restore(snapshot)
    return {
        "cpu": cpu, "wall": wall, "raw_cpu": raw_cpu, "raw_wall": raw_wall, "ticks": ticks,
        "success": result.success, "failure": result.failure, "exact": bool(np.array_equal(replayed_qpos, final_qpos)),
    }


def summarise(samples: list[dict]) -> dict:
    """Per-primitive figures from :func:`measure` results."""
    from collections import Counter

    count = len(samples)
    total = {key: sum(sample[key] for sample in samples) for key in ("cpu", "wall", "raw_cpu", "raw_wall", "ticks")}

    def per(seconds: float) -> float:
        return count / seconds if seconds else 0.0

    return {
        "samples": count,
        "executions_per_cpu_second": per(total["cpu"]),
        "executions_per_second": per(total["wall"]),
        "raw_executions_per_cpu_second": per(total["raw_cpu"]),
        "ratio_to_raw_mj_step": total["cpu"] / total["raw_cpu"] if total["raw_cpu"] else None,
        "ratio_to_raw_mj_step_wall": total["wall"] / total["raw_wall"] if total["raw_wall"] else None,
        "mean_ticks": total["ticks"] / max(count, 1),
        "heuristic_success_rate": sum(sample["success"] for sample in samples) / max(count, 1),
        "failures": dict(Counter(str(sample["failure"]) for sample in samples)),
        "replay_exact": sum(sample["exact"] for sample in samples) / max(count, 1),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sim", default="mujoco")
    parser.add_argument("--json", dest="json_out", required=True)
    parser.add_argument("--samples", type=int, default=40)
    parser.add_argument("--only", default="", help="comma-separated primitives (default: all)")
    parser.add_argument("--set", dest="options", action="append", default=[], metavar="OPTION=VALUE",
                        help="simulator option, e.g. substeps=8 (repeatable; default: the plugin's defaults)")
    args = parser.parse_args()
    options = {}
    for item in args.options:
        key, separator, value = item.partition("=")
        if not separator:
            parser.error(f"--set {item!r}: expected OPTION=VALUE, e.g. substeps=8")
        options[key] = value

    from rich.progress import track

    from t2m_core.cli.sim_cmd import resolve_simulator
    from t2m_core.domain.primitives import get_primitive

    sim = resolve_simulator(args.sim, options)
    if not hasattr(sim, "world"):
        parser.error(f"--sim {args.sim}: the raw mj_step reference needs a MuJoCo simulator (one with a .world)")
    only = set(filter(None, args.only.split(",")))
    results = {}
    for name, (task_id, keep, setup, (primitive, arguments)) in CASES.items():
        if only and name not in only:
            continue
        task = case_scene(task_id, keep)
        rng = np.random.default_rng(0)
        samples = []
        for _reset in track(distinct_scenes(sim, task, args.samples), total=args.samples, description=f"{name:5s}", transient=True):
            if not prepare(sim, setup, rng):
                continue
            action = get_primitive(primitive).heuristic_action(sim.geometric_state(), arguments, rng)
            samples.append(measure(sim, primitive, arguments, action))
        results[name] = figures = summarise(samples)
        print(f"{name:5s} {figures['executions_per_cpu_second']:6.1f} exec/CPU-s  {figures['executions_per_second']:6.1f} exec/s wall  "
              f"{figures['mean_ticks']:5.0f} ticks  raw mj_step {figures['raw_executions_per_cpu_second']:6.1f}/CPU-s  "
              f"ratio {figures['ratio_to_raw_mj_step']:.2f} (wall {figures['ratio_to_raw_mj_step_wall']:.2f})  "
              f"replay exact {figures['replay_exact']:.0%}  (n={figures['samples']})")
    write_json_atomic(args.json_out, {
        "simulator": args.sim,
        "options": sim.options.model_dump() if hasattr(sim, "options") else options,
        "method": "CPU: time.process_time; raw: bare mj_step replay of the recorded per-tick inputs",
        "primitives": results,
    })


if __name__ == "__main__":
    main()
