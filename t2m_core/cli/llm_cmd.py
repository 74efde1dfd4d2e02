"""``t2m llm``: ask the language model Text2Motion's questions about one task scene.

- ``t2m llm goal --task ID --seed N [--instruction TEXT] [--llm NAME] [--json]``: the predicted
  goal alternatives, or "no valid goal" and why; with the task's own instruction, whether the goal
  means the task's ground truth (strict and plan-level, judged on the states reachable from the
  scene: docs/guide/language-models.md#judging-goals); exits 1 when no valid goal came back or, for
  the task's instruction, a shortest plan to the goal can miss the task's goal (plan-level);
- ``t2m llm next --task ID --seed N --executed "pick(a),place(a, rack)"``: the K candidate next
  skills with their log-likelihoods and usefulness scores.

The scene is the task's initial state sampled for the seed (no physics); relationships after the
executed skills follow from the skills' symbolic effects.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any

import typer

if TYPE_CHECKING:
    from t2m_core.language.session import LanguageSession
    from t2m_core.tasks import Task

llm_app = typer.Typer(name="llm", help="Query the language model about a task scene (goal, next skills).", no_args_is_help=True)

TaskOption = Annotated[str, typer.Option("--task", help="Task id (task3), number (3) or name (lh_lg_po_2).")]
SeedOption = Annotated[int, typer.Option("--seed", help="Scene seed; also fixes the in-context example order.")]
LlmOption = Annotated[str, typer.Option("--llm", help="Language model: local, gpt-4o, litellm/<model>, ollama/<model>, replay...")]
SetOption = Annotated[
    list[str] | None, typer.Option("--set", help="Language-model option KEY=VALUE (repeatable), e.g. --set n_ctx=4096.")
]
JsonOption = Annotated[bool, typer.Option("--json", help="Print JSON on stdout.")]
TranscriptOption = Annotated[Path | None, typer.Option("--transcript", help="Append every request and response to this JSONL file.")]
ConstrainedOption = Annotated[
    bool, typer.Option("--constrained/--free", help="Grammar-constrained decoding where the backend supports it.")
]


def _session(
    task_id: str,
    seed: int,
    llm: str,
    settings: list[str] | None,
    transcript: Path | None,
    constrained: bool,
    instruction: str | None = None,
) -> tuple[Task, LanguageSession]:
    """The task and a language session on its scene for ``seed`` (the model built from
    ``--llm``/``--set``), asking ``instruction`` instead of the task's when given."""
    from dataclasses import replace

    from rich.console import Console

    from t2m_core.config.resolve import parse_override
    from t2m_core.errors import ConfigError
    from t2m_core.language.scene_description import describe_task_scene
    from t2m_core.language.selection import create_language_model
    from t2m_core.language.session import LanguageSession
    from t2m_core.tasks import load_task

    options: dict[str, Any] = {}
    for text in settings or []:
        path, value = parse_override(text)
        if len(path) != 1:
            raise ConfigError(f"--set {text!r}: language-model options are single keys", hint="e.g. --set n_ctx=4096")
        options[path[0]] = value
    task = load_task(task_id)
    scene, _ = describe_task_scene(task, seed)
    if instruction is not None:
        scene = replace(scene, instruction=instruction.strip())
    with Console(stderr=True).status(f"loading language model {llm!r}"):
        model = create_language_model(llm, options, transcript=transcript)
    return task, LanguageSession(model, scene, seed=seed, constrained=constrained)


@llm_app.command("goal")
def goal_command(
    task: TaskOption,
    seed: SeedOption = 0,
    instruction: Annotated[
        str | None, typer.Option("--instruction", help="Ask this instead of the task's instruction, on the task's scene.")
    ] = None,
    llm: LlmOption = "local",
    settings: SetOption = None,
    transcript: TranscriptOption = None,
    constrained: ConstrainedOption = True,
    as_json: JsonOption = False,
) -> None:
    """Predict the goal of the task's instruction (or --instruction) as DNF alternatives.

    Exits 1 when the model gives no valid goal or, for the task's own instruction, a goal whose
    shortest plans can miss the task's goal alternatives (plan-level judgement)."""
    from rich.console import Console

    from t2m_core.language.goal_judging import judge_goal, reachable_states
    from t2m_core.tasks.symbolic_model import initial_facts

    task_spec, session = _session(task, seed, llm, settings, transcript, constrained, instruction)
    with Console(stderr=True).status("predicting the goal"):
        query = session.predict_goal()
    own = instruction is None
    judgement = judge_goal(query.goal, task_spec.goal, reachable_states(initial_facts(task_spec), task_spec.objects)) if own else None
    report = {
        "task": task_spec.id,
        "seed": seed,
        "instruction": session.scene.instruction,
        "relationships": list(session.scene.relationships),
        "valid": query.goal is not None,
        "goal": None if query.goal is None else query.goal.to_lists(),
        "no_goal": None if query.no_goal is None else {"kind": query.no_goal.kind, "reason": query.no_goal.reason},
        "matches_task_goal": None if judgement is None else judgement.strict,
        "plan_level_match": None if judgement is None else judgement.plan_level,
        "attempts": [{"answer": attempt.answer, "problem": attempt.problem} for attempt in query.attempts],
    }
    failed = query.goal is None or (own and not report["plan_level_match"])
    if as_json:
        typer.echo(json.dumps(report, indent=2))
        if failed:
            raise typer.Exit(1)
        return
    console = Console()
    console.print(f"[bold]{task_spec.id}[/bold] seed {seed}: {report['instruction']}")
    for index, attempt in enumerate(query.attempts, start=1):
        status = "[green]valid[/green]" if attempt.problem is None else f"[red]invalid[/red]: {attempt.problem}"
        console.print(f"attempt {index}: {attempt.answer.strip()}  ({status})", markup=True, highlight=False)
    if query.no_goal is not None:
        console.print(f"[red]no valid goal[/red]: {query.no_goal.reason}", highlight=False)
        raise typer.Exit(1)
    if query.goal is None:
        console.print("[red]no valid goal after the retries: a planning failure[/red]")
        raise typer.Exit(1)
    for index, alternative in enumerate(query.goal.to_lists(), start=1):
        console.print(f"  alternative {index}: {', '.join(alternative)}", highlight=False)
    if own:
        console.print(f"matches the task's goal alternatives: {report['matches_task_goal']} "
                      f"(every shortest plan reaches them: {report['plan_level_match']})")
    if failed:
        raise typer.Exit(1)


@llm_app.command("next")
def next_command(
    task: TaskOption,
    seed: SeedOption = 0,
    executed: Annotated[str, typer.Option("--executed", help='Skills already executed: "pick(a),place(a, rack)".')] = "",
    goal: Annotated[
        str | None, typer.Option("--goal", help="Goal shown in the prompt: a list of lists, or 'task' for the task's own; default: predict it.")
    ] = None,
    llm: LlmOption = "local",
    settings: SetOption = None,
    transcript: TranscriptOption = None,
    constrained: ConstrainedOption = True,
    as_json: JsonOption = False,
) -> None:
    """Generate K candidate next skills after EXECUTED and score each one (S_llm, β = 0.3)."""
    from rich.console import Console

    from t2m_core.domain.goals import parse_goal, validate_goal
    from t2m_core.language.session import parse_executed

    task_spec, session = _session(task, seed, llm, settings, transcript, constrained)
    calls = parse_executed(executed, task_spec.objects)
    status = Console(stderr=True).status("querying the language model")
    with status:
        if goal == "task":
            prompt_goal = task_spec.goal
        elif goal:
            prompt_goal = parse_goal(goal)
            validate_goal(prompt_goal, task_spec.objects)
        else:
            status.update("predicting the goal")
            query = session.predict_goal()
            if query.goal is None:
                why = f" ({query.no_goal.reason})" if query.no_goal else ""
                raise typer.BadParameter(f"the model gave no valid goal{why}; pass one with --goal", param_hint="--goal")
            prompt_goal = query.goal
        status.update("generating candidates")
        candidates, attempts = session.generate_next(prompt_goal, calls)
        status.update("scoring candidates")
        scored = session.score(prompt_goal, calls, candidates)
    rows = [{"skill": str(call), "logprob": logprob, "usefulness": usefulness} for call, logprob, usefulness in scored.ranked()]
    report = {
        "task": task_spec.id,
        "seed": seed,
        "executed": [str(call) for call in calls],
        "goal": prompt_goal.to_lists(),
        "relationships": list(session.current_relationships(calls)),
        "candidates": rows,
        "exact_scores": session.model.capabilities.exact_scoring,
        "attempts": [{"answer": attempt.answer, "problem": attempt.problem} for attempt in attempts],
    }
    if as_json:
        typer.echo(json.dumps(report, indent=2))
        return
    from rich.table import Table

    console = Console()
    console.print(f"[bold]{task_spec.id}[/bold] seed {seed}, goal {prompt_goal}", highlight=False)
    console.print(f"after {report['executed'] or 'nothing'}: {', '.join(report['relationships'])}", highlight=False)
    table = Table(title=f"next-skill candidates ({'exact' if report['exact_scores'] else 'approximate'} scores)")
    for column in ("rank", "skill", "log-likelihood", "S_llm"):
        table.add_column(column, justify="right" if column != "skill" else "left")
    for rank, row in enumerate(rows, start=1):
        table.add_row(str(rank), row["skill"], f"{row['logprob']:.3f}", f"{row['usefulness']:.3f}")
    console.print(table)
    if not rows:
        console.print("[red]no valid candidate[/red]: " + "; ".join(str(a["problem"]) for a in report["attempts"]))
        raise typer.Exit(1)


def register(app: typer.Typer) -> None:
    """Add ``t2m llm`` to the root app."""
    app.add_typer(llm_app, name="llm")
