"""``t2m tasks``: list the language task suite; ``t2m tasks show ID --seed N``: sample one initial
state and print it (object poses and sizes, the accepted seed, the symbolic state)."""

from __future__ import annotations

import json
from typing import TYPE_CHECKING, Annotated, Any

import typer

if TYPE_CHECKING:
    from t2m_core.domain.sampling import SampledScene
    from t2m_core.tasks import Task

tasks_app = typer.Typer(
    name="tasks",
    help="List the language tasks, or sample and show one task's initial state.",
    invoke_without_command=True,
    no_args_is_help=False,
)

JsonOption = Annotated[bool, typer.Option("--json", help="Print JSON on stdout instead of a table.")]


def task_rows() -> list[dict[str, Any]]:
    """One row per shipped task: ``id, name, properties, paper_task, instruction, objects``."""
    from t2m_core.tasks import list_tasks

    return [
        {
            "id": task.id,
            "name": task.name,
            "properties": list(task.properties),
            "paper_task": task.paper_task,
            "instruction": task.instruction,
            "objects": list(task.objects),
        }
        for task in list_tasks()
    ]


@tasks_app.callback()
def list_tasks_command(ctx: typer.Context, as_json: JsonOption = False) -> None:
    """List every task: id, properties and the instruction."""
    if ctx.invoked_subcommand is not None:
        return
    rows = task_rows()
    if as_json:
        typer.echo(json.dumps(rows, indent=2))
        return
    from rich.console import Console
    from rich.table import Table

    table = Table(title="t2m tasks", title_justify="left")
    for column in ("id", "name", "properties", "instruction"):
        table.add_column(column, overflow="fold")
    for row in rows:
        table.add_row(row["id"], row["name"], ", ".join(row["properties"]), row["instruction"])
    Console().print(table)


@tasks_app.command("show")
def show_command(
    task_id: Annotated[str, typer.Argument(metavar="ID", help="Task id (task3), number (3) or name (lh_lg_po_2).")],
    seed: Annotated[int, typer.Option("--seed", help="First candidate seed; seed+1, ... follow on rejection.")] = 0,
    as_json: JsonOption = False,
) -> None:
    """Sample the task's initial state for SEED and print it (poses in metres, quaternions xyzw)."""
    from t2m_core.domain.sampling import sample_task
    from t2m_core.tasks import load_task

    task = load_task(task_id)
    scene = sample_task(task, seed)
    report = scene_report(task, seed, scene)
    if as_json:
        typer.echo(json.dumps(report, indent=2))
        return
    _print_scene(report)


def scene_report(task: Task, seed: int, scene: SampledScene) -> dict[str, Any]:
    """A JSON-ready description of a sampled initial state."""
    from t2m_core.domain.objects import object_spec
    from t2m_core.domain.relations import symbolic_state

    state = scene.state
    return {
        "task": task.id,
        "seed": seed,
        "accepted_seed": scene.accepted_seed,
        "rejections": scene.rejections,
        "objects": [
            {
                "name": name,
                "position": _rounded(pose.position),
                "quaternion": _rounded(pose.quaternion),
                "size": list(object_spec(name).size),
            }
            for name, pose in state.objects.items()
        ],
        "held": state.held,
        "robot_pose": {"position": _rounded(scene.robot_pose.position), "yaw": round(scene.robot_pose.yaw, 6)},
        "initial_state": [str(p) for p in task.initial_state],
        "symbolic_state": [str(p) for p in symbolic_state(state, task.objects)],
    }


def _rounded(values: Any) -> list[float]:
    """Micrometre / micro-unit precision keeps the JSON readable and exact enough."""
    return [round(float(v), 6) for v in values]


def _print_scene(report: dict[str, Any]) -> None:
    from rich.console import Console
    from rich.table import Table

    console = Console()
    console.print(
        f"[bold]{report['task']}[/] seed {report['seed']}: accepted seed {report['accepted_seed']} "
        f"after {report['rejections']} rejection(s)",
        highlight=False,
    )
    table = Table(title_justify="left")
    for column in ("object", "position (m)", "quaternion (xyzw)", "size (m)"):
        table.add_column(column)
    for row in report["objects"]:
        table.add_row(
            row["name"],
            _format(row["position"], 3),
            _format(row["quaternion"], 3),
            _format(row["size"], 3),
        )
    console.print(table)
    robot = report["robot_pose"]
    console.print(f"robot pose target: {_format(robot['position'], 3)}, yaw {robot['yaw']:.3f} rad", highlight=False)
    if report["held"]:
        console.print(f"held: {report['held']}", highlight=False)
    console.print("symbolic state: " + ", ".join(report["symbolic_state"]), highlight=False, soft_wrap=True)


def _format(values: list[float], digits: int) -> str:
    return "(" + ", ".join(f"{v:.{digits}f}" for v in values) + ")"


def register(app: typer.Typer) -> None:
    """Add ``tasks`` and ``tasks show`` to the root app."""
    app.add_typer(tasks_app)
