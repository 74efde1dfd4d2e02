"""Options of the feasibility planners (``--set feasibility_planner.options.<key>=...``)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import AfterValidator, BaseModel, ConfigDict, Field

from t2m_core.domain.literals import LiteralSyntaxError, parse_call
from t2m_core.domain.objects import ObjectKind
from t2m_core.domain.skills import SKILLS, SkillCall

VETO_SKILLS = ("pick", "pull", "push", "place")
"""The skills whose primitives predict from the domain's geometry when an action drives something into
another object (:mod:`t2m_stap.geometric_veto`)."""

def veto_entry(text: str) -> str:
    """A ``veto`` entry, normalised: a skill of :data:`VETO_SKILLS` (every call of it) or a lifted
    call, the skill with its arguments' object kinds (``place(hook, table)``: the hook set down on
    the table; see :attr:`~t2m_core.domain.skills.SkillCall.lifted`).

    Raises:
        ValueError: naming the entry and the forms an entry takes.
    """
    forms = f"use a skill ({', '.join(VETO_SKILLS)}) or a skill with object kinds, e.g. place(hook, table)"
    if "(" not in text:
        name, kinds = text.strip(), None
    else:
        try:
            name, kinds = parse_call(text, "veto entry")
        except LiteralSyntaxError as error:
            raise ValueError(f"{text!r}: {error.message}; {forms}") from None
    if name not in VETO_SKILLS:
        raise ValueError(f"{text!r} names no skill with a geometric prediction; {forms}")
    if kinds is None:
        return name
    known = [kind.value for kind in ObjectKind]
    if len(kinds) != SKILLS[name].arity or any(kind not in known for kind in kinds):
        raise ValueError(f"{text!r}: {name} takes {SKILLS[name].arity} object kind(s) of {', '.join(known)}; {forms}")
    return str(SkillCall(name, kinds))


VetoEntry = Annotated[str, AfterValidator(veto_entry)]
"""One entry of the ``veto`` option (:func:`veto_entry`)."""


VETO_FIRST = (
    "entries of the same forms as veto's, vetoed at the skeleton's first skill only: the one a closed loop executes next, "
    "judged at the observed state rather than at a predicted one, and the one veto thins out of a long skeleton's samples least"
)


class SamplingOptions(BaseModel):
    """What every sampling planner shares."""

    model_config = ConfigDict(extra="forbid")

    population: int = Field(10_000, ge=1, description="trajectories sampled per iteration")
    scale_population_by_horizon: bool = Field(
        False, description="sample population × 4T trajectories (the original implementation) instead of population"
    )
    seed: int = Field(0, ge=0, description="seed of the planner's random draws; a plan is deterministic for a seed")
    chunk_size: int = Field(
        20_000, ge=1, description="trajectories rolled out per batch (bounds memory; CEM results do not depend on it)"
    )
    ood_penalty: bool = Field(False, description="optimise the OOD-masked product instead of reporting the flags only")
    veto: list[VetoEntry] = Field(
        default_factory=list, description="skills (pick, pull, push, place) or lifted calls (place(hook, table)) whose actions get the value 0 "
        "where the domain's geometry predicts them to drive the fingers, the hook, the box or the held object into another object (a deviation: the method "
        "judges with the ensembles alone)"
    )
    veto_first: list[VetoEntry] = Field(default_factory=list, description=VETO_FIRST)

    def samples(self, horizon: int) -> int:
        """Trajectories per iteration for a skeleton of ``horizon`` skills."""
        return self.population * (4 * horizon if self.scale_population_by_horizon else 1)


CPU_POPULATION = 500
"""PolicyCEM's default samples per iteration: the paper's 10 000 bought no success on this CPU at 25
times the time, and over-optimised the learned values more often (docs/guide/deviations.md#policycem-population-and-spread)."""


DEFAULT_VETO = ["pick", "pull"]
"""PolicyCEM vetoes grasps and pulls that the domain's geometry predicts to strike another object:
the hybrid planner reached 55 of the suite's 70 episodes with it, 48 without
(docs/guide/deviations.md#geometric-veto-on-grasps-and-pulls)."""


DEFAULT_VETO_FIRST = ["place(hook, table)"]
"""PolicyCEM also vetoes the hook's placement on the table when it is the skill executed next: tasks
3 to 6 reached 35 of 40 episodes with it, 29 without, no plan before that step changes, and the
whole suite reached 61 of 70 (docs/guide/feasibility.md#vetoed-at-the-first-step)."""


SigmaMode = Literal["constant", "adaptive"]
"""How CEM's σ evolves: held at its initial value (the paper) or re-estimated from the elites (the original)."""


DEFAULT_SIGMA_MODE: SigmaMode = "adaptive"
"""PolicyCEM re-estimates σ from the elites each iteration (the original implementation; the paper
holds σ = 0.3): the hybrid planner reached 113 of the suite's 140 episodes on seeds 0-19 with it,
108 with the constant spread (docs/guide/deviations.md#policycem-population-and-spread)."""


class CEMOptions(SamplingOptions):
    """The cross-entropy method (PolicyCEM by default: the paper's settings, except
    :data:`CPU_POPULATION` samples per iteration, the spread of :data:`DEFAULT_SIGMA_MODE`, the
    geometric veto on :data:`DEFAULT_VETO` and, at the first step, on :data:`DEFAULT_VETO_FIRST`)."""

    population: int = Field(CPU_POPULATION, ge=1, description="trajectories sampled per iteration (the paper: 10 000)")
    veto: list[VetoEntry] = Field(
        default_factory=lambda: list(DEFAULT_VETO),
        description="as every sampling planner's, here on grasps and pulls by default ([]: the published judgement by the ensembles alone)",
    )
    veto_first: list[VetoEntry] = Field(
        default_factory=lambda: list(DEFAULT_VETO_FIRST),
        description="as every sampling planner's, here on the hook's placement on the table by default",
    )
    iterations: int = Field(10, ge=1, description="CEM iterations")
    elites: int = Field(10, ge=1, description="elite trajectories kept per iteration")
    keep_elites: bool = Field(True, description="carry the elites into the next iteration's population")
    sigma: float = Field(0.3, gt=0, description="initial standard deviation, normalised action units")
    sigma_mode: SigmaMode = Field(
        DEFAULT_SIGMA_MODE, description="adaptive: sigma re-estimated as the elites' std each iteration, floored at 1e-4 "
        "(the original implementation, the default); constant: sigma held (the paper)"
    )
    clip_grasps: bool = Field(
        False, description="clamp every sampled grasp of a box to a grasp point at least 1 cm inside its faces (x and y in the "
        "box's frame) before it is rolled out, and search them with sigma scaled to that range: grasp points beside a box or at "
        "its faces close on nothing"
    )
    restarts: int = Field(
        1, ge=1, description="independent CEM runs from the same start, drawn one after another from the seed's "
        "random stream; the best score wins (1: the paper's single run)"
    )


class RandomCEMOptions(CEMOptions):
    """RandomCEM: seeded by a uniform-random rollout, sigma 1.0 held constant, 10 000 × 4T samples."""

    population: int = Field(10_000, ge=1, description="trajectories sampled per iteration (× 4T)")
    sigma: float = Field(1.0, gt=0, description="initial standard deviation, normalised action units")
    scale_population_by_horizon: bool = Field(True, description="sample population × 4T trajectories")
    veto: list[VetoEntry] = Field(default_factory=list, description="as PolicyCEM's; none by default (the published baseline)")
    veto_first: list[VetoEntry] = Field(default_factory=list, description="as PolicyCEM's; none by default (the published baseline)")
    sigma_mode: SigmaMode = Field(
        "constant", description="as PolicyCEM's; constant by default (the published baseline)"
    )


class ShootingOptions(SamplingOptions):
    """One pass of sampled trajectories; the best wins (100 000 × 4T samples)."""

    population: int = Field(100_000, ge=1, description="trajectories sampled")
    scale_population_by_horizon: bool = Field(True, description="sample population × 4T trajectories")
    sigma: float = Field(0.3, gt=0, description="PolicyShooting: std of the noise on the policy's actions")


class PolicyOptions(BaseModel):
    """The deterministic policy rollout: nothing to search."""

    model_config = ConfigDict(extra="forbid")

    veto: list[VetoEntry] = Field(
        default_factory=list, description="skills (pick, pull, push, place) or lifted calls (place(hook, table)) whose actions are reported "
        "with the value 0 where the domain's geometry predicts them to drive something into another object"
    )
    veto_first: list[VetoEntry] = Field(default_factory=list, description=VETO_FIRST)
