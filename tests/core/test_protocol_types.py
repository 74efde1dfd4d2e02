"""The protocols name the value types they exchange (no ``Any`` where a concrete type exists)."""

from __future__ import annotations

import typing

import numpy as np
import torch

from t2m_core import protocols
from t2m_core.domain.goals import Goal
from t2m_core.domain.skills import SkillCall
from t2m_core.language.session import LanguageSession
from t2m_core.tasks import Task

_NAMES = {"np": np, "torch": torch, "Goal": Goal, "SkillCall": SkillCall, "LanguageSession": LanguageSession, "Task": Task}


def _hints(obj: object) -> dict[str, object]:
    return typing.get_type_hints(obj, globalns=vars(protocols), localns=_NAMES)


def test_planner_and_skill_protocols_resolve_to_concrete_types() -> None:
    assert _hints(protocols.Simulator.reset)["task"] is Task
    assert typing.get_args(_hints(protocols.FeasibilityPlanner.plan)["skeleton"]) == (SkillCall,)
    context = _hints(protocols.PlanningContext)
    assert context["goal"] is Goal
    assert context["session"] is LanguageSession
    assert typing.get_args(_hints(protocols.TaskPlan)["skeleton"]) == (SkillCall,)
    for method in ("policy", "q_values", "predict"):
        hints = _hints(getattr(protocols.Skill, method))
        assert all(value is protocols.Batch for value in hints.values()), (method, hints)
    assert set(protocols.Batch.__constraints__) == {typing.ForwardRef("np.ndarray"), typing.ForwardRef("torch.Tensor")}


def test_no_any_left_in_the_planner_skill_and_feasibility_protocols() -> None:
    for owner in (protocols.Skill, protocols.FeasibilityPlanner, protocols.TaskPlanner):
        for name, member in vars(owner).items():
            if callable(member) and not name.startswith("_"):
                assert typing.Any not in _hints(member).values(), (owner.__name__, name)
    for owner in (protocols.PlanningContext, protocols.TaskPlan):
        assert typing.Any not in _hints(owner).values(), owner.__name__


def test_importing_the_protocols_does_not_import_torch() -> None:
    import subprocess
    import sys

    code = "import sys, t2m_core.protocols; print('torch' in sys.modules)"
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip() == "False"
