"""Registers the STAP feasibility planners. Import-light: torch loads only when one is built."""

from __future__ import annotations

from t2m_core.hookspecs import hookimpl
from t2m_core.plugin_specs import FeasibilityPlannerSpec
from t2m_stap.options import CEMOptions, PolicyOptions, RandomCEMOptions, ShootingOptions

FEASIBILITY_PLANNERS = [
    FeasibilityPlannerSpec(
        name="policy-cem",
        factory="t2m_stap.planners:policy_cem",
        options=CEMOptions,
        summary="STAP PolicyCEM: CEM seeded by the policies' rollout, 10 x 500 samples, spread from the elites (Text2Motion's, default)",
    ),
    FeasibilityPlannerSpec(
        name="random-cem",
        factory="t2m_stap.planners:random_cem",
        options=RandomCEMOptions,
        summary="CEM seeded by a uniform-random rollout, sigma 1.0 (baseline)",
    ),
    FeasibilityPlannerSpec(
        name="policy-shooting",
        factory="t2m_stap.planners:policy_shooting",
        options=ShootingOptions,
        summary="One pass of noisy policy rollouts; the best wins (baseline)",
    ),
    FeasibilityPlannerSpec(
        name="random-shooting",
        factory="t2m_stap.planners:random_shooting",
        options=ShootingOptions,
        summary="One pass of uniform-random action sequences; the best wins (baseline)",
    ),
    FeasibilityPlannerSpec(
        name="policy",
        factory="t2m_stap.planners:policy_only",
        options=PolicyOptions,
        summary="The deterministic policy rollout alone; reports its Q product (baseline)",
    ),
]


@hookimpl
def t2m_register_feasibility_planners() -> list[FeasibilityPlannerSpec]:
    return FEASIBILITY_PLANNERS
