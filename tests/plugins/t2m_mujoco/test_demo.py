import numpy as np
import pytest
from typer.testing import CliRunner

from t2m_core.cli.main import app
from t2m_core.demo import run_demo
from t2m_core.skeleton_search import search_skeleton
from t2m_core.tasks import load_task
from t2m_mujoco.options import MujocoOptions
from t2m_mujoco.simulator import MujocoSimulator


@pytest.mark.slow
def test_demo_reaches_task0_goal_and_records(tmp_path):
    sim = MujocoSimulator(MujocoOptions(render_width=64, render_height=48, video_fps=5))
    result = run_demo(sim, load_task("task0"), 0, tmp_path)
    assert result["success"], result["failure"]
    assert [step["skill"] for step in result["steps"]] == [str(c) for c in load_task("task0").reference_skeleton]
    assert all(step["success"] and step["tries"] >= 1 for step in result["steps"])
    assert (tmp_path / "video.mp4").stat().st_size > 1000


def test_search_reports_exhaustion():
    """A skeleton whose first skill cannot succeed (pick of a box beyond reach) is not found."""
    sim = MujocoSimulator(MujocoOptions(render_width=64, render_height=48))
    task = load_task("task3")
    sim.reset(task, seed=0)
    from t2m_core.domain.skills import SkillCall

    search = search_skeleton(sim, [SkillCall("pick", ("blue_box",))], np.random.default_rng(0), tries_per_skill=4)
    assert not search.found and search.tries == [4] and search.failures == {"not_in_workspace": 4}


def test_cli_lists_demo():
    result = CliRunner().invoke(app, ["sim", "demo", "--help"])
    assert result.exit_code == 0 and "--task" in result.output and "--out" in result.output
