"""One console line per plan-tree record (docs/guide/run-records.md#plan_treejsonl): the live view of
``t2m run`` and the replay of ``t2m show``."""

from __future__ import annotations

from typing import Any


def render_event(console: Any, event: dict[str, Any]) -> None:
    """Print what one plan-tree record says the planner did."""
    kind = event.get("event")
    if kind == "goal":
        console.print(f"goal: {event['goal']}")
    elif kind == "shooting_candidate":
        mark = "[green]kept[/]" if event.get("kept") else "[dim]dropped[/]"
        console.print(f"  shooting {event['sequence']}: values [{_values(event)}] {mark} ({event.get('reason')})")
    elif kind == "greedy_step":
        console.print(f"greedy step {len(event.get('prefix', [])) + 1}" + (f", after {event['prefix'][-1]}" if event.get("prefix") else ""))
        for c in event.get("candidates", []):
            console.print(f"  {c['skill']}: usefulness {c['usefulness']:.2f} x feasibility {c['feasibility']:.2f} = "
                          f"{c['score']:.3f}, plan p_success {c.get('p_success', 0.0):.3f} {_mark(c)}")
    elif kind == "backtrack":
        console.print(f"  [yellow]backtrack[/] ({event.get('reason')}): {event['prefix']} + {event['chosen']}")
    elif kind == "myopic_step":
        for c in event.get("candidates", []):
            console.print(f"  {c['skill']}: usefulness {c['usefulness']:.2f} x value {c['value']:.2f}{' <-' if c.get('chosen') else ''}")
    elif kind == "plan":
        console.print(f"plan: {event['skeleton']} " + ("" if event.get("found") else f"[red]planning failure[/]: {event.get('failure')}"))
    elif kind == "executed":
        outcome = "[green]success[/]" if event.get("success") else f"[red]{event.get('failure')}[/]"
        console.print(f"  executed {event['skill']} (value {event.get('value', 0.0):.2f}): {outcome}")


def _values(event: dict[str, Any]) -> str:
    return " ".join(f"{v:.2f}" for v in event.get("values", []))


def _mark(candidate: dict[str, Any]) -> str:
    """Why a greedy candidate was or was not taken."""
    if candidate.get("chosen"):
        return "[green]<-[/]"
    notes = [name for name in ("revisit", "regression") if candidate.get(name)]
    return f"[dim]{', '.join(notes)}[/]" if notes else ""
