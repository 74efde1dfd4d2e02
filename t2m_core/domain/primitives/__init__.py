"""TableEnv motion primitives as backend-independent specifications (tableenv.md §10).

:data:`PRIMITIVES` maps each primitive's name to its specification; a backend executes the
:class:`~t2m_core.domain.primitives.base.MotionStep` s that :meth:`Primitive.motion` returns.
"""

from __future__ import annotations

from t2m_core.domain.primitives.base import (
    FAILURES,
    MotionKind,
    MotionStep,
    Outcome,
    Primitive,
    StepContext,
    first_disturbed,
    is_truncated,
)

PRIMITIVES: dict[str, Primitive] = {}
"""Primitive name -> specification (filled as the primitives land)."""

__all__ = [
    "FAILURES",
    "PRIMITIVES",
    "MotionKind",
    "MotionStep",
    "Outcome",
    "Primitive",
    "StepContext",
    "first_disturbed",
    "is_truncated",
]
