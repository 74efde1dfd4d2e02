"""STAP feasibility planners: PolicyCEM (Text2Motion's) and its baselines, optimising a skill
sequence's parameters through the skills' learned dynamics (docs/guide/feasibility.md)."""
