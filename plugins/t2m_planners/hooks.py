"""Registers the task planners. Import-light: nothing heavy is imported until one is built."""

from __future__ import annotations

from t2m_core.hookspecs import hookimpl
from t2m_core.plugin_specs import TaskPlannerSpec
from t2m_planners.options import HybridOptions, LookaheadOptions, MyopicOptions

TASK_PLANNERS = [
    TaskPlannerSpec(
        name="hybrid",
        aliases=("text2motion",),
        factory="t2m_planners.lookahead:hybrid",
        options=HybridOptions,
        summary="Text2Motion: shooting first, greedy-search steps as the fallback, STAP-verified (default)",
    ),
    TaskPlannerSpec(
        name="shooting",
        factory="t2m_planners.lookahead:shooting",
        options=LookaheadOptions,
        summary="One query for K whole sequences; the most feasible goal-reaching one",
    ),
    TaskPlannerSpec(
        name="greedy-search",
        factory="t2m_planners.lookahead:greedy_search",
        options=LookaheadOptions,
        summary="One skill at a time by language usefulness x STAP feasibility",
    ),
    TaskPlannerSpec(
        name="saycan-gs",
        factory="t2m_planners.myopic:saycan_gs",
        options=MyopicOptions,
        summary="Myopic baseline: SayCan with a generator-scorer, plan one skill, execute, repeat",
    ),
    TaskPlannerSpec(
        name="innermono-gs",
        factory="t2m_planners.myopic:innermono_gs",
        options=MyopicOptions,
        summary="Myopic baseline: Inner Monologue (scene feedback after every execution)",
    ),
]


@hookimpl
def t2m_register_task_planners() -> list[TaskPlannerSpec]:
    return TASK_PLANNERS
