"""The reference-skeleton demo behind ``t2m sim demo``: search a task's reference skeleton
(:func:`t2m_core.skeleton_search.search_skeleton`), replay the found actions from a fresh reset of
the same seed while recording a video, and report whether the task's goal holds at the end.
"""

from __future__ import annotations

import contextlib
import time
from pathlib import Path
from typing import Any

import numpy as np

from t2m_core.skeleton_search import search_skeleton


def run_demo(
    simulator: Any, task: Any, seed: int, out_dir: Path | None, *, rng_seed: int | None = None
) -> dict[str, Any]:
    """Search the reference skeleton of ``task`` from ``seed``, replay it (recording ``out_dir/video.mp4``
    when ``out_dir`` is given) and return the ``result.json`` content."""
    from t2m_core.domain.goals import goal_satisfied_full

    started = time.perf_counter()
    reset = simulator.reset(task, seed=seed)
    search = search_skeleton(simulator, task.reference_skeleton, np.random.default_rng(seed if rng_seed is None else rng_seed))
    replay_reset = simulator.reset(task, seed=seed)
    steps: list[dict[str, Any]] = []
    recording = contextlib.nullcontext(None)
    if out_dir is not None:
        from t2m_core.video import VideoWriter

        # the writer discards its partial file when the replay raises
        recording = VideoWriter(out_dir / "video.mp4", fps=getattr(getattr(simulator, "options", None), "video_fps", 15))
    failure = None
    with recording as video:
        if video is not None:
            video.add(simulator.render())
            if hasattr(simulator, "stream_frames"):  # optional: backends without it give a still video
                simulator.stream_frames(video.add)
        try:
            padded_actions = [*search.actions, *[None] * len(task.reference_skeleton)]
            for call, tries, action in zip(task.reference_skeleton, search.tries, padded_actions, strict=False):
                if action is None:
                    steps.append({"skill": str(call), "success": False, "tries": tries})
                    continue
                outcome = simulator.execute(call.name, call.args, action)
                steps.append({"skill": str(call), "success": bool(outcome.success), "tries": tries, "failure": outcome.failure})
                if not outcome.success:
                    failure = failure or f"replay of {call} failed: {outcome.failure}"
            final_state = simulator.geometric_state()
            reached = bool(goal_satisfied_full(task.goal, final_state, task.initial_state))
            if video is not None:
                for _ in range(8):  # about half a second of the final scene
                    video.add(simulator.render())
        finally:
            if hasattr(simulator, "stream_frames"):
                simulator.stream_frames(None)
    if not search.found:
        failure = failure or f"no parameters found for {task.reference_skeleton[len(search.actions)]}"
    elif not reached:
        failure = failure or "every skill succeeded but the goal does not hold"
    return {
        "success": reached and search.found,
        "task": task.id,
        "seed": seed,
        "accepted_seed": reset.accepted_seed,
        "replay_accepted_seed": replay_reset.accepted_seed,
        "steps": steps,
        "failure": failure,
        "failure_counts": search.failures,
        "executions": search.executions,
        "seconds": round(time.perf_counter() - started, 2),
    }
