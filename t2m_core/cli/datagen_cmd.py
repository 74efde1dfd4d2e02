"""``t2m datagen``: generate skill data (a thin layer over :func:`t2m_core.data.generate.generate_dataset`)."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Annotated

import typer

from t2m_core.atomic_files import ensure_writable_directory
from t2m_core.cli.executor_flags import AddressFlag, ExecutorFlag, task_status
from t2m_core.errors import T2MError


def datagen(
    skill: Annotated[str, typer.Option("--skill", help="pick, place, pull, push, or all.")],
    split: Annotated[str, typer.Option("--split", help="train, validation or invalid (OOD calibration, not simulated).")],
    size: Annotated[int, typer.Option("--size", min=1, help="Transitions per skill in the split.")],
    out: Annotated[Path, typer.Option("--out", help="Dataset directory (DIR/<skill>/<split>/...).")],
    workers: Annotated[int, typer.Option("--workers", min=0, help="Chunks generated at once (0: one per core, or per CPU of the Ray cluster).")] = 0,
    executor: ExecutorFlag = "local",
    address: AddressFlag = None,
    sim: Annotated[str, typer.Option("--sim", help="Simulator plugin (see `t2m list-plugins`).")] = "mujoco",
    seed: Annotated[int, typer.Option("--seed", min=0, help="Base seed of the dataset.")] = 0,
    chunk_size: Annotated[int, typer.Option("--chunk-size", min=1, help="Transitions per shard.")] = 250,
    sampler: Annotated[
        str, typer.Option("--sampler", help="Action sampler: screened (default), heuristic, uniform, proposal (a skill library's planner proposals) "
                     "planned (the feasibility planner's own actions along task rollouts; needs --scenes tasks) "
                     "or obstructed (pull and push: half the screened draws replaced by sweeps into a bystander).")
    ] = "screened",
    actions_per_scene: Annotated[
        int, typer.Option("--actions-per-scene", min=1, help="Actions executed from each reset scene (restored exactly between them); above 1 makes data cheaper.")
    ] = 1,
    proposal_checkpoints: Annotated[
        Path | None,
        typer.Option("--proposal-checkpoints", help="With --sampler proposal or planned: the checkpoints it proposes with (default: the library's shipped ones)."),
    ] = None,
    proposal_library: Annotated[str, typer.Option("--proposal-library", help="With --sampler proposal or planned: the skill library plugin.")] = "tableenv",
    scenes: Annotated[
        str,
        typer.Option("--scenes", help="Where transitions start: data (enumerated symbolic states, default), tasks (states reached along "
                     "the task suite's reference skeletons; needs --sampler proposal or planned), tasks:ID,ID (those tasks' skeletons only) "
                     "or evaluation (the single-skill scenes a policy's success is reported in, other instances)."),
    ] = "data",
    skeleton: Annotated[
        str | None,
        typer.Option("--skeleton", help='With --scenes tasks:ID (one task): roll out this skill sequence instead of the reference one, '
                     'e.g. "pick(hook), pull(blue_box, hook), place(hook, table)" (another order a planner may choose).'),
    ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the manifests as JSON on stdout.")] = False,
) -> None:
    """Generate (or finish generating) a split of skill data: simulated transitions of symbolically
    valid skills (train, validation) or unsimulated invalid ones (invalid). Rerunning the same
    command resumes: finished shards are kept. With --executor ray the chunks run on a Ray cluster,
    whose nodes must all see --out; the shards are the same bytes either way."""
    from t2m_core.data.chunks import LIBRARY_SAMPLERS, SCENES, ProposalSource, rollout_scenes
    from t2m_core.data.generate import DatasetJob, default_workers, generate_dataset
    from t2m_core.data.proposals import checkpoint_digest, library_digest
    from t2m_core.data.scenes import DATA_SKILLS
    from t2m_core.executors import make_executor
    from t2m_core.registry import get_registry

    skills = DATA_SKILLS if skill == "all" else (skill,)
    if skill != "all" and skill not in DATA_SKILLS:
        raise T2MError(f"unknown skill {skill!r}", f"use one of: {', '.join(DATA_SKILLS)}, all")
    if split != "invalid":
        sim = get_registry().get("simulator", sim).name  # an unknown name fails here, with the choices
    if scenes.partition(":")[0] not in SCENES:
        raise T2MError(f"unknown scene source {scenes!r}", f"use one of: {', '.join(SCENES)}, or tasks:ID,ID")
    rollouts = rollout_scenes(scenes)
    if rollouts and sampler not in LIBRARY_SAMPLERS:
        raise T2MError("--scenes tasks advances along the skeletons with a skill library's proposals", "add --sampler proposal (or planned)")
    if proposal_checkpoints is not None and sampler not in LIBRARY_SAMPLERS:
        raise T2MError("--proposal-checkpoints is for the proposal and planned samplers", "add --sampler proposal, or drop --proposal-checkpoints")
    if skeleton is not None:
        from t2m_core.domain.skills import parse_skeleton

        skeleton = ", ".join(str(call) for call in parse_skeleton(skeleton))  # canonical spacing: the same order, the same dataset
    proposal_directory = _proposal_directory(proposal_library, proposal_checkpoints) if sampler in LIBRARY_SAMPLERS and split != "invalid" else None
    ensure_writable_directory(out)
    jobs = []
    for name in skills:
        proposal = None
        if proposal_directory is not None:
            digest = library_digest(proposal_directory, DATA_SKILLS) if rollouts else checkpoint_digest(proposal_directory, name)
            proposal = ProposalSource(proposal_library, str(proposal_directory), digest)
        job = DatasetJob(out.resolve(), name, split, size, chunk_size, seed, sampler, sim, actions_per_scene=actions_per_scene, proposal=proposal,
                         scenes=scenes, skeleton=skeleton)
        job.chunks()  # checks every setting (a task, a skeleton) before any work starts
        jobs.append(job)
    manifests = {}
    with make_executor(executor, workers=workers or (default_workers() if executor == "local" else 0), address=address) as pool:
        for job in jobs:
            manifests[job.skill] = _run_with_progress(job, pool, generate_dataset)
    if as_json:
        typer.echo(json.dumps(manifests, indent=2))


def _proposal_directory(library: str, checkpoints: Path | None) -> Path:
    """The proposal sampler's checkpoints: ``checkpoints``, or the directory the library loads by
    default (its options' ``checkpoint_directory``)."""
    from t2m_core.registry import get_registry

    if checkpoints is not None:
        return checkpoints.resolve()
    spec = get_registry().get("skill_library", library)
    default = getattr(spec.options(), "checkpoint_directory", None)
    if default is None:
        raise T2MError(f"the skill library {library!r} names no default checkpoints", "give --proposal-checkpoints DIR")
    return Path(default).resolve()


def _run_with_progress(job, executor, generate) -> dict:
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    console = Console(stderr=True)
    started = time.perf_counter()
    columns = (
        TextColumn(f"[bold]{job.skill}[/] {job.split}"),
        BarColumn(),
        MofNCompleteColumn(),
        TextColumn("{task.fields[rate]} transitions/s"),
        TextColumn("success {task.fields[success]}"),
        TextColumn("{task.fields[tasks]}"),
        TimeElapsedColumn(),
        TimeRemainingColumn(),
    )
    with Progress(*columns, console=console, transient=False) as bar:
        task = bar.add_task("chunks", total=None, rate="-", success="-", tasks="")

        def update(progress) -> None:
            elapsed = time.perf_counter() - started
            rate = f"{progress.new_transitions / elapsed:.1f}" if progress.new_transitions else "-"
            success = f"{progress.successes / progress.transitions:.0%}" if progress.transitions else "-"
            tasks = task_status(progress.running, progress.failed, progress.retried)
            bar.update(task, total=progress.chunks_total, completed=progress.chunks_done, rate=rate, success=success, tasks=tasks)

        manifest = generate(job, executor=executor, on_progress=update)
    console.print(
        f"{job.skill} {job.split}: {manifest['count']} transitions, success rate {manifest['success_rate']:.1%} "
        f"-> {job.directory} ({executor.name} executor, {executor.workers} worker{'s' if executor.workers > 1 else ''})"
    )
    return manifest


def register(app: typer.Typer) -> None:
    """Add ``t2m datagen`` to the root app."""
    app.command("datagen")(datagen)
