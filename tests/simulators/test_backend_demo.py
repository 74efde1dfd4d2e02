"""``t2m sim demo`` on every builtin backend (docs/guide/simulators.md#t2m-sim-demo)."""

import numpy as np
import pytest

from t2m_core.cli.sim_cmd import resolve_simulator
from t2m_core.demo import run_demo
from t2m_core.domain.skills import SkillCall
from t2m_core.skeleton_search import search_skeleton
from t2m_core.tasks import load_task
from tests.simulators.backends import BACKENDS, make_simulator


@pytest.mark.slow
@pytest.mark.parametrize("backend", BACKENDS)
def test_demo_reaches_task0_goal_and_records(backend, tmp_path):
    sim = make_simulator(backend, render_width=64, render_height=48, video_fps=5)
    try:
        result = run_demo(sim, load_task("task0"), 0, tmp_path)
    finally:
        sim.close()
    assert result["success"], result["failure"]
    assert [step["skill"] for step in result["steps"]] == [str(c) for c in load_task("task0").reference_skeleton]
    assert all(step["success"] and step["tries"] >= 1 for step in result["steps"])
    assert (tmp_path / "video.mp4").stat().st_size > 1000


@pytest.mark.parametrize("backend", BACKENDS)
def test_search_reports_exhaustion(backend):
    """A skeleton whose first skill cannot succeed (pick of a box beyond reach) is not found."""
    sim = make_simulator(backend, render_width=64, render_height=48)
    try:
        sim.reset(load_task("task3"), seed=0)
        search = search_skeleton(sim, [SkillCall("pick", ("blue_box",))], np.random.default_rng(0), tries_per_skill=4)
    finally:
        sim.close()
    assert not search.found and search.tries == [4] and search.failures == {"not_in_workspace": 4}


@pytest.mark.parametrize("backend", BACKENDS)
def test_sim_flag_reaches_every_backend(backend):
    """``t2m sim demo --sim NAME`` builds its simulator through the plugin registry."""
    sim = resolve_simulator(backend, {"render_width": 64, "render_height": 48})
    try:
        assert type(sim).__module__ == f"t2m_{backend}.simulator"
        assert sim.options.render_width == 64
    finally:
        sim.close()
