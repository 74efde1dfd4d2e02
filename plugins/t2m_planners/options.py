"""Options of the task planners (``--set task_planner.options.<key>=...``)."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field
from pydantic.fields import FieldInfo

AllowOrSkip = Literal["allow", "skip"]
Revisits = Literal["allow", "skip", "last"]


class PlannerOptions(BaseModel):
    """The constants every planner shares (docs/guide/planners.md#scores)."""

    model_config = ConfigDict(extra="forbid")

    k: int = Field(5, ge=1, le=20, description="skills or sequences the language model proposes per query (K)")
    beta: float = Field(0.3, gt=0, description="softmax dampening of the language-model scores")
    max_depth: int = Field(10, ge=1, le=30, description="most skills in a plan or an episode (d_max)")


class LookaheadOptions(PlannerOptions):
    """Options of hybrid, shooting and greedy-search."""

    tau: float = Field(0.2, ge=0, le=1, description="a goal-reaching plan needs every OOD-masked step value above tau")
    geometric_score: Literal["last", "product"] = Field(
        "last", description="greedy S_geo: the masked value of the new step (paper) or the product over the prefix"
    )
    feasible_truncation: Literal["through", "before"] = Field(
        "through",
        description="shooting truncation needs steps up to and including t to pass tau (through) or, as the "
        "original's off-by-one did, only the steps before t (before)",
    )
    proposals: Literal["generated", "grounded"] = Field(
        "generated",
        description="greedy candidates: the K skills the language model generates (paper), or every symbolically "
        "valid grounding, each scored by the language model (grounded)",
    )
    revisits: Revisits = Field(
        "allow",
        description="greedy candidates whose predicted situation repeats one already on the planned path: chosen "
        "like any other (allow, paper), never chosen (skip), or, when one puts a box down, chosen only at a step where "
        "no other candidate can be (last; other revisits never are)",
    )
    below_tau: AllowOrSkip = Field(
        "allow",
        description="greedy candidates whose plan has a masked step value at or below tau, so that no plan through "
        "them can be accepted: chosen like any other (allow, paper) or never chosen (skip)",
    )
    regressions: AllowOrSkip = Field(
        "allow",
        description="greedy candidates that undo a goal proposition the planned prefix achieved (one false in the "
        "start state), such as taking a box off the rack the plan put it on: chosen like any other (allow, "
        "paper) or never chosen (skip)",
    )
    backtracks: int = Field(
        0,
        ge=0,
        le=50,
        description="dead ends (no greedy candidate can be chosen, or d_max reached) resumed at the latest earlier "
        "step's next-best candidate, at most this many per episode (0: the dead end fails the search, as the "
        "paper's beam of one)",
    )
    prefix_start: Literal["policy", "planned"] = Field(
        "policy",
        description="where STAP starts a candidate's plan (prefix plus candidate): from the policies' rollout, "
        "re-planning the prefix from scratch (policy, paper), or from the actions already planned for the "
        "prefix, the policy's after them (planned), so that a longer plan never starts worse than its prefix",
    )
    backtrack_to: Literal["latest", "most_feasible"] = Field(
        "latest",
        description="where a dead end resumes: at the latest earlier step's next-best candidate (latest, "
        "depth first), or at the candidate, of any earlier step, whose planned prefix has the largest masked "
        "p_success (most_feasible)",
    )


class MyopicOptions(PlannerOptions):
    """Options of saycan-gs and innermono-gs."""

    stop_value: float = Field(0.5, ge=0, description="the feasibility value of stop()")
    stop_value_when_top: float = Field(10.0, ge=0, description="stop()'s value when the language model ranks it first")


def _with_default(name: str, default: object) -> FieldInfo:
    """A :class:`LookaheadOptions` field (description, bounds) with another default."""
    return FieldInfo.merge_field_infos(LookaheadOptions.model_fields[name], default=default)


class HybridOptions(LookaheadOptions):
    """Options of hybrid: the lookahead ones, with the search options of
    docs/guide/planners.md#search-options-beyond-the-paper on by default
    (docs/guide/deviations.md#a-greedy-step-that-does-not-loop), τ = 0.1 for t2m's pessimistic
    learned values (docs/guide/deviations.md#tau-01-for-pessimistic-values), and the shooting query
    only from the empty prefix (docs/guide/deviations.md#one-shooting-query-per-episode)."""

    proposals: Literal["generated", "grounded"] = _with_default("proposals", "grounded")  # type: ignore[assignment]
    revisits: Revisits = _with_default("revisits", "last")  # type: ignore[assignment]
    below_tau: AllowOrSkip = _with_default("below_tau", "skip")  # type: ignore[assignment]
    backtracks: int = _with_default("backtracks", 5)  # type: ignore[assignment]
    regressions: AllowOrSkip = _with_default("regressions", "skip")  # type: ignore[assignment]
    backtrack_to: Literal["latest", "most_feasible"] = _with_default("backtrack_to", "most_feasible")  # type: ignore[assignment]
    tau: float = _with_default("tau", 0.1)  # type: ignore[assignment]
    reshoot: Literal["every_step", "never"] = Field(
        "never",
        description="shooting queries after the first: one after every greedy step, from the longer prefix "
        "(every_step, the published interleaving), or none, so that the greedy steps finish the plan (never: "
        "about one generation call of 10 s saved per greedy step, the same outcomes in the episodes measured; "
        "docs/guide/planners.md#re-shooting)",
    )
