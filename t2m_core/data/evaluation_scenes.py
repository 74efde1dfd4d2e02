"""Single-skill evaluation scenes: every instance has a feasible action, so a policy's success rate
in them measures the policy, not the scene (docs/guide/skills.md#evaluation-scenes).

The argument box is drawn per episode; its rejection predicates (``free``, ``inworkspace``,
``beyondworkspace``, ``nonblocking``, ``inoperationalzone``, ``infront``) make the instance feasible.
Pull and Push also fix where the hand holds the hook, as the reach of each needs: Pull by the
handle's tail half (``handlegrasp``: the head reaches a box beyond the workspace), Push near the head
(``upperhandlegrasp``: the sweep towards a rack beyond the workspace stays within the arm's reach).
With a random grasp many scenes had no feasible action; the screened sampler's success in 100
scenes (seed 0), random / tail / upper grasp: Pull 56 / 98 / 40 %, Push 40 / 31 / 74 %
(docs/guide/skills.md#evaluation-scenes).
"""

from __future__ import annotations

import numpy as np

from t2m_core.data.scenes import DataTask, symbolic_states
from t2m_core.domain.propositions import Proposition, canonical_order
from t2m_core.domain.skills import SkillCall

BOXES = ("red_box", "blue_box", "yellow_box", "cyan_box")
RACK = ("aligned(rack)", "poslimit(rack)", "on(rack, table)")


def _scene(skill: str, box: str, target: str) -> tuple[tuple[str, ...], tuple[str, ...], SkillCall]:
    if skill == "pick":
        props = (*RACK, "inworkspace(rack)", "on(hook, table)", f"on({box}, table)", f"free({box})", f"inworkspace({box})")
        return ("table", "rack", "hook", box), props, SkillCall("pick", (box,))
    if skill == "place":
        return ("table", "rack", box), (*RACK, "inworkspace(rack)", f"inhand({box})"), SkillCall("place", (box, target))
    if skill == "pull":
        props = (*RACK, "inworkspace(rack)", "inhand(hook)", "handlegrasp(hook)", f"on({box}, table)", f"free({box})", f"beyondworkspace({box})", f"nonblocking({box}, rack)")
        return ("table", "rack", "hook", box), props, SkillCall("pull", (box, "hook"))
    if skill == "push":
        props = (*RACK, "beyondworkspace(rack)", "inhand(hook)", "upperhandlegrasp(hook)", f"on({box}, table)", f"free({box})", f"inoperationalzone({box})", f"infront({box}, rack)")
        return ("table", "rack", "hook", box), props, SkillCall("push", (box, "hook", "rack"))
    raise ValueError(f"unknown skill {skill!r}")


def evaluation_task(skill: str, rng: np.random.Generator) -> DataTask:
    """An evaluation scene of ``skill`` with a random box (and, for Place, a random support)."""
    box = BOXES[int(rng.integers(len(BOXES)))]
    target = ("table", "rack")[int(rng.integers(2))]
    objects, texts, call = _scene(skill, box, target)
    propositions = canonical_order(Proposition.parse(t) for t in texts)
    symbolic = frozenset(p for p in propositions if p.predicate in ("on", "inhand") or p.args == ("rack",) and p.predicate in ("aligned", "poslimit", "inworkspace", "beyondworkspace"))
    index = next(i for i, state in enumerate(symbolic_states()) if state.facts == symbolic)
    return DataTask(id=f"{call} (evaluation)", objects=objects, initial_state=propositions, symbolic_state=index, call=call)
