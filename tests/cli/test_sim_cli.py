"""``t2m sim demo`` reports a missed goal with a non-zero exit status (stub simulator, no physics)."""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
from typer.testing import CliRunner

from t2m_core.cli.main import app
from t2m_core.domain.sampling import sample_task
from t2m_core.hookspecs import hookimpl
from t2m_core.plugin_specs import SimulatorSpec

runner = CliRunner()


class FailingSimulator:
    """Resets to the sampled scene; every primitive execution fails with a collision."""

    def __init__(self, _options=None):
        self.state = None
        self.closed = False

    def reset(self, task, seed):
        self.state = sample_task(task, seed).state
        return SimpleNamespace(accepted_seed=seed)

    def get_state(self):
        return self.state

    def set_state(self, state):
        self.state = state

    def geometric_state(self):
        return self.state

    def execute(self, name, args, action):
        return SimpleNamespace(success=False, failure="collision", contacts=())

    def render(self):
        return np.zeros((8, 8, 3), dtype=np.uint8)

    def close(self):
        self.closed = True


def test_demo_exits_nonzero_when_the_goal_is_not_reached(t2m_registry, t2m_plugin, tmp_path):
    def register():
        return [SimulatorSpec(name="failing", factory=FailingSimulator, summary="test double")]

    t2m_plugin(SimpleNamespace(t2m_register_simulators=hookimpl(register)), name="failing")
    out = tmp_path / "demo"
    result = runner.invoke(app, ["sim", "demo", "--task", "task0", "--sim", "failing", "--out", str(out)])
    assert result.exit_code == 1, result.output
    written = json.loads((out / "result.json").read_text(encoding="utf-8"))
    assert not written["success"] and written["failure"].startswith("no parameters found for pick(")
    assert written["failure_counts"] == {"collision": written["executions"]}
