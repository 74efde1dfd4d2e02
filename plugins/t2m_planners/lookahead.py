"""The lookahead planners: shooting, greedy-search and Text2Motion's hybrid (docs/guide/planners.md).

All three plan every candidate sequence with the feasibility planner from the start state, read the
predicted states to describe the planned prefix to the language model and to test the goal, and
accept a goal-reaching plan only when every OOD-masked step value exceeds τ.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from t2m_core.domain.goals import goal_satisfied
from t2m_core.domain.objects import ObjectKind, object_spec
from t2m_core.domain.observation import decode_observation
from t2m_core.domain.propositions import Proposition
from t2m_core.domain.relations import situation, symbolic_state
from t2m_core.domain.skills import SkillCall
from t2m_core.domain.state import GeometricState
from t2m_core.language.prompts import HistoryStep
from t2m_core.language.scene_description import relationships_of
from t2m_core.protocols import PlanningContext, PlanResult, TaskPlan
from t2m_planners.options import HybridOptions, LookaheadOptions


def masked_values(plan: PlanResult) -> np.ndarray:
    """``(T,)`` the step values with OOD steps zeroed: ṽ_t = v_t · (1 − o_t)."""
    return np.asarray(plan.values, dtype=np.float64) * ~np.asarray(plan.ood, dtype=bool)


def truncated(plan: PlanResult, steps: int) -> PlanResult:
    """``plan`` restricted to its first ``steps`` skills."""
    values, ood = plan.values[:steps], plan.ood[:steps]
    return PlanResult(
        plan.actions[:steps], plan.states[: steps + 1], values, ood, float(np.prod(values * ~ood)),
        None if plan.variances is None else plan.variances[:steps],
        None if plan.q_members is None else plan.q_members[:steps],
    )


def continuations(prefix: Sequence[SkillCall], proposed: list[SkillCall]) -> list[list[SkillCall]]:
    """The continuations of ``prefix`` a shooting answer ``proposed`` stands for.

    A model often restarts its answer inside the planned prefix. When ``proposed`` begins with the
    whole prefix, that repeat is dropped. When it begins with only the prefix's last skills (the
    longest such overlap: ``pick(hook)`` planned, ``pick(hook), pull(...)`` proposed), both readings
    are returned, the overlap dropped first: STAP and the product of values choose between them.
    """
    overlap = next((k for k in range(min(len(prefix), len(proposed)), 0, -1) if proposed[:k] == list(prefix[-k:])), 0)
    if not overlap:
        return [proposed]
    return [proposed[overlap:]] if overlap == len(prefix) else [proposed[overlap:], proposed]


@dataclass
class Candidate:
    """A scored next-skill candidate of a greedy step."""

    call: SkillCall
    plan: PlanResult
    logprob: float
    usefulness: float
    feasibility: float
    revisit: bool = False
    """Its predicted situation repeats one already on the planned path (docs/guide/planners.md#revisited-states)."""
    regression: bool = False
    """It undoes a goal proposition the planned prefix achieved (docs/guide/planners.md#regressions)."""

    @property
    def score(self) -> float:
        return self.usefulness * self.feasibility


class Search:
    """The shared machinery of one lookahead planning episode: STAP calls, the goal test on
    predicted states, prompt histories, counters and plan-tree events."""

    def __init__(self, context: PlanningContext, options: LookaheadOptions) -> None:
        self.context = context
        self.options = options
        self.objects = tuple(context.object_names)
        self.llm_calls = 0
        self.stap_calls = 0
        self.held_at_start = self.achieved(decode_observation(context.observation, self.objects))
        """The goal propositions that already hold in the start state (never counted as achieved)."""

    # --- helpers of the algorithms ----------------------------------------------------------------

    def emit(self, event: str, **fields: Any) -> None:
        if self.context.on_event is not None:
            self.context.on_event({"event": event, **fields})

    def stap(self, sequence: Sequence[SkillCall], prefix_plan: PlanResult | None = None) -> PlanResult:
        """STAP's plan of ``sequence``; with ``prefix_start="planned"``, started from ``prefix_plan``'s
        actions (the plan already made for the first steps of ``sequence``)."""
        self.stap_calls += 1
        extra = {}
        if self.options.prefix_start == "planned" and prefix_plan is not None:
            extra["initial_actions"] = prefix_plan.actions
        return self.context.feasibility.plan(self.context.observation, list(sequence), self.context.skills, self.objects, **extra)

    def ok(self, plan: PlanResult, steps: int) -> bool:
        """Every masked value of the first ``steps`` steps exceeds τ."""
        return bool(np.all(masked_values(plan)[:steps] > self.options.tau))

    def satisfied(self, plan: PlanResult, steps: int) -> bool:
        """The goal holds on the predicted state after ``steps`` skills."""
        return goal_satisfied(self.context.goal, decode_observation(plan.states[steps], self.objects), self.objects)

    def history(self, plan: PlanResult | None, prefix: Sequence[SkillCall]) -> list[HistoryStep]:
        """The planned prefix as prompt history lines, with the relationships of the latest predicted states."""
        if plan is None or not prefix:
            return []
        return [
            HistoryStep(str(call), relationships_of(decode_observation(plan.states[k + 1], self.objects), self.objects))
            for k, call in enumerate(prefix)
        ]

    def settled(self, before: GeometricState, after: np.ndarray, call: SkillCall) -> GeometricState:
        """The predicted state ``after`` ``call`` with every object the call does not name kept where it
        was ``before``: only a skill's arguments move, and the dynamics' small drift of the others must
        not make a repeated situation look new."""
        state = decode_observation(after, self.objects)
        poses = {name: pose if name in call.args else before.objects.get(name, pose) for name, pose in state.objects.items()}
        return replace(state, objects=poses)

    def path_states(self, plan: PlanResult | None, prefix: Sequence[SkillCall]) -> list[GeometricState]:
        """The start state and the settled predicted state after each skill of the planned prefix."""
        states = [decode_observation(self.context.observation if plan is None else plan.states[0], self.objects)]
        for k, call in enumerate(prefix):
            states.append(self.settled(states[-1], plan.states[k + 1], call))
        return states

    def achieved(self, state: GeometricState) -> frozenset[Proposition]:
        """The goal's propositions (of any alternative) that hold in ``state``."""
        return frozenset(self.context.goal.propositions).intersection(symbolic_state(state, self.objects))

    @staticmethod
    def plan_fields(plan: PlanResult) -> dict[str, Any]:
        return {
            "values": [round(float(v), 4) for v in plan.values],
            "ood": [bool(o) for o in plan.ood],
            "p_success": round(float(plan.p_success), 6),
        }

    # --- the algorithms ---------------------------------------------------------------------------

    def shooting(self, prefix: list[SkillCall], prefix_plan: PlanResult | None, depth_left: int) -> tuple[list[SkillCall], PlanResult] | None:
        """One shooting query continuing ``prefix``; the most feasible goal-reaching truncation, or ``None``."""
        sequences, attempts = self.context.session.generate_sequences(
            self.context.goal, prefix, history=self.history(prefix_plan, prefix)
        )
        self.llm_calls += len(attempts)
        found: list[tuple[float, list[SkillCall], PlanResult]] = []
        seen: set[tuple[SkillCall, ...]] = set()
        for continuation in (c for proposed in sequences for c in continuations(prefix, list(proposed))):
            if not continuation or tuple(continuation) in seen:
                continue
            seen.add(tuple(continuation))
            full = prefix + continuation
            if len(continuation) > depth_left:
                self.emit("shooting_candidate", prefix=[str(c) for c in prefix], sequence=[str(c) for c in full], kept=False, reason="longer than the remaining depth")
                continue
            plan = self.stap(full, prefix_plan)
            reason = "the goal does not hold on any predicted state"
            for steps in range(len(prefix) + 1, len(full) + 1):
                feasible = self.ok(plan, steps if self.options.feasible_truncation == "through" else steps - 1)
                if not feasible:
                    reason = f"step {steps} ({full[steps - 1]}) or an earlier one is at or below tau, or out of distribution"
                    break
                if self.satisfied(plan, steps):
                    product = float(np.prod(masked_values(plan)[:steps]))
                    found.append((product, full[:steps], truncated(plan, steps)))
                    reason = f"reaches the goal after {steps} skills"
                    break
            self.emit("shooting_candidate", prefix=[str(c) for c in prefix], sequence=[str(c) for c in full], **self.plan_fields(plan),
                      kept=reason.startswith("reaches"), reason=reason)
        if not found:
            return None
        product, sequence, plan = max(found, key=lambda item: item[0])
        self.emit("shooting_choice", sequence=[str(c) for c in sequence], p_success=round(product, 6))
        return sequence, plan

    def greedy_step(self, prefix: list[SkillCall], prefix_plan: PlanResult | None) -> list[Candidate] | None:
        """The next-skill candidates (the K the model generates, or every valid grounding with
        ``proposals="grounded"``), each planned with the prefix and scored S_llm · S_geo."""
        history = self.history(prefix_plan, prefix)
        if self.options.proposals == "grounded":
            calls = self.context.session.groundings(prefix, history)
        else:
            proposed, attempts = self.context.session.generate_next(self.context.goal, prefix, history=history)
            self.llm_calls += len(attempts)
            calls = list(dict.fromkeys(proposed))
        if not calls:
            self.emit("greedy_step", prefix=[str(c) for c in prefix], candidates=[], reason="no valid next skill was proposed")
            return None
        plans = [self.stap(prefix + [call], prefix_plan) for call in calls]
        scored = self.context.session.score(self.context.goal, prefix, calls, history=history)
        self.llm_calls += 1
        path = self.path_states(prefix_plan, prefix)
        visited = {situation(state, self.objects) for state in path}
        achieved = self.achieved(path[-1]) - self.held_at_start
        candidates = []
        for call, plan, logprob, usefulness in zip(calls, plans, scored.logprobs, scored.usefulness, strict=True):
            masked = masked_values(plan)
            feasibility = float(masked[-1]) if self.options.geometric_score == "last" else float(np.prod(masked))
            after = self.settled(path[-1], plan.states[-1], call)
            revisit = situation(after, self.objects) in visited
            regression = not achieved <= self.achieved(after)
            candidates.append(Candidate(call, plan, float(logprob), float(usefulness), feasibility, revisit, regression))
        return candidates

    def terminal(self, prefix: list[SkillCall], candidates: list[Candidate]) -> Candidate | None:
        """The best goal-reaching candidate whose every step passes τ (by masked product), or ``None``."""
        steps = len(prefix) + 1
        reaching = [c for c in candidates if self.satisfied(c.plan, steps) and self.ok(c.plan, steps)]
        return max(reaching, key=lambda c: float(np.prod(masked_values(c.plan)))) if reaching else None

    def ranked(self, prefix: list[SkillCall], candidates: list[Candidate]) -> list[Candidate]:
        """The candidates the search may append, best S_skill first: all of them, as in the paper,
        less revisits (``revisits="skip"``; with ``"last"``, those that put a box down stay when no
        other candidate is left), regressions (``regressions="skip"``) and those with a step at or
        below τ (``below_tau="skip"``)."""
        steps = len(prefix) + 1
        kept = [
            c for c in candidates
            if not (self.options.regressions == "skip" and c.regression) and not (self.options.below_tau == "skip" and not self.ok(c.plan, steps))
        ]
        if self.options.revisits == "allow":
            return sorted(kept, key=lambda c: -c.score)
        fresh = [c for c in kept if not c.revisit]
        if not fresh and self.options.revisits == "last":
            fresh = [c for c in kept if places_box(c.call)]
        return sorted(fresh, key=lambda c: -c.score)

    def record_step(self, prefix: list[SkillCall], candidates: list[Candidate], chosen: Candidate | None, terminal: bool) -> None:
        self.emit(
            "greedy_step",
            prefix=[str(c) for c in prefix],
            candidates=[
                {
                    "skill": str(c.call),
                    "logprob": round(c.logprob, 4) if math.isfinite(c.logprob) else None,
                    "usefulness": round(c.usefulness, 4),
                    "feasibility": round(c.feasibility, 4),
                    "score": round(c.score, 6),
                    **self.plan_fields(c.plan),
                    "chosen": c is chosen,
                    "revisit": c.revisit,
                    "regression": c.regression,
                    "goal_reached": terminal and c is chosen,
                }
                for c in candidates
            ],
        )

    def result(self, skeleton: Sequence[SkillCall], plan: PlanResult | None, failure: str | None) -> TaskPlan:
        return TaskPlan(list(skeleton), plan, failure, False, self.llm_calls, self.stap_calls)


class LookaheadPlanner:
    """``hybrid`` (Text2Motion: shooting first, a greedy step as fallback, shooting again from the
    longer prefix unless ``reshoot="never"``), ``shooting`` (one query) and ``greedy-search`` (one
    skill at a time)."""

    def __init__(self, options: LookaheadOptions | None = None, mode: str = "hybrid") -> None:
        if mode not in ("hybrid", "shooting", "greedy-search"):
            raise ValueError(f"unknown lookahead mode {mode!r}")
        self.options = options or (HybridOptions() if mode == "hybrid" else LookaheadOptions())
        self.mode = mode
        self.reshoot = not isinstance(self.options, HybridOptions) or self.options.reshoot == "every_step"
        """Hybrid queries shooting again after every greedy step (otherwise only from the empty prefix)."""

    def plan(self, context: PlanningContext) -> TaskPlan:
        search = Search(context, self.options)
        d_max = self.options.max_depth
        if self.mode == "shooting":
            shot = search.shooting([], None, d_max)
            return search.result(*shot, None) if shot else search.result([], None, "no proposed sequence reaches the goal with every step feasible")
        prefix: list[SkillCall] = []
        prefix_plan: PlanResult | None = None
        alternatives: list[tuple[list[SkillCall], PlanResult | None, list[Candidate]]] = []  # per greedy step taken
        backtracks = 0
        while True:
            ranked: list[Candidate] = []
            if len(prefix) < d_max:
                if self.mode == "hybrid" and (not prefix or self.reshoot):
                    shot = search.shooting(prefix, prefix_plan, d_max - len(prefix))
                    if shot is not None:
                        return search.result(*shot, None)
                candidates = search.greedy_step(prefix, prefix_plan)
                if candidates is None:
                    return search.result(prefix, prefix_plan, "no valid next skill was proposed")
                terminal = search.terminal(prefix, candidates)
                if terminal is not None:
                    search.record_step(prefix, candidates, terminal, True)
                    return search.result(prefix + [terminal.call], terminal.plan, None)
                ranked = search.ranked(prefix, candidates)
                search.record_step(prefix, candidates, ranked[0] if ranked else None, False)
            if not ranked:  # a dead end: d_max reached, or no candidate can be chosen
                dead_end = f"no goal-reaching plan within {d_max} skills" if len(prefix) >= d_max else (
                    "no candidate next skill can be chosen (each returns to a situation already on the plan or has a step at or below tau)")
                ended = (prefix, prefix_plan)
                if backtracks < self.options.backtracks:
                    prefix, prefix_plan, ranked = resume(alternatives, self.options.backtrack_to)
                if not ranked:
                    return search.result(*ended, dead_end)
                backtracks += 1
                search.emit("backtrack", prefix=[str(c) for c in prefix], chosen=str(ranked[0].call), reason=dead_end)
            best = ranked.pop(0)
            if len(prefix) + 1 < d_max:  # at the last step no other candidate reached the goal: none to resume
                alternatives.append((prefix, prefix_plan, ranked))
            prefix, prefix_plan = prefix + [best.call], best.plan


def places_box(call: SkillCall) -> bool:
    """Whether ``call`` puts a box down. Where it lands was chosen for the prefix alone, so such a
    revisit may be the step a longer plan needs (a box put aside, out of a later sweep), while a
    revisit of the hook's pick or placement repeats by construction (a situation leaves the hook's
    pose out), and a pull or pick that leaves every zone as it was moves nothing a goal needs."""
    return call.name == "place" and object_spec(call.args[0]).kind is ObjectKind.BOX


def resume(
    alternatives: list[tuple[list[SkillCall], PlanResult | None, list[Candidate]]], order: str
) -> tuple[list[SkillCall], PlanResult | None, list[Candidate]]:
    """Take, from the candidates left at earlier greedy steps (``alternatives``: one entry per step
    taken, each with its remaining candidates, best S_skill first), the step a dead end resumes at,
    with the candidate to take next moved to the front of its list: the latest step with one left
    (``"latest"``), or the candidate whose planned prefix has the largest masked p_success
    (``"most_feasible"``). The empty list of candidates when none is left."""
    while alternatives and not alternatives[-1][2]:
        alternatives.pop()
    if not alternatives:
        return [], None, []
    if order == "latest":
        return alternatives.pop()
    options = [(float(np.prod(masked_values(c.plan))), i, j) for i, (_, _, ranked) in enumerate(alternatives) for j, c in enumerate(ranked)]
    _, i, j = max(options, key=lambda item: (item[0], item[1], -item[2]))  # ties: the later step, then the better score
    prefix, prefix_plan, ranked = alternatives.pop(i)
    return prefix, prefix_plan, [ranked[j], *ranked[:j], *ranked[j + 1 :]]


def hybrid(options: HybridOptions) -> LookaheadPlanner:
    return LookaheadPlanner(options, "hybrid")


def shooting(options: LookaheadOptions) -> LookaheadPlanner:
    return LookaheadPlanner(options, "shooting")


def greedy_search(options: LookaheadOptions) -> LookaheadPlanner:
    return LookaheadPlanner(options, "greedy-search")
