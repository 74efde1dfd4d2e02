"""TableEnv motion primitives as backend-independent specifications (docs/guide/primitives.md).

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
from t2m_core.domain.primitives.pick import Pick
from t2m_core.domain.primitives.place import Place
from t2m_core.domain.primitives.pull import Pull
from t2m_core.domain.primitives.push import Push
from t2m_core.domain.primitives.stop import Stop

PRIMITIVES: dict[str, Primitive] = {p.name: p for p in (Pick(), Place(), Pull(), Push(), Stop())}
"""Primitive name -> specification with the published defaults (d_Pull = d_Push = 0.05 m)."""


def get_primitive(name: str) -> Primitive:
    """The primitive called ``name``; raises ``KeyError`` listing the known primitives."""
    try:
        return PRIMITIVES[name]
    except KeyError:
        raise KeyError(f"unknown primitive {name!r}; known primitives: {', '.join(PRIMITIVES)}") from None

__all__ = [
    "FAILURES",
    "PRIMITIVES",
    "Pick",
    "Place",
    "Pull",
    "Push",
    "Stop",
    "get_primitive",
    "MotionKind",
    "MotionStep",
    "Outcome",
    "Primitive",
    "StepContext",
    "first_disturbed",
    "is_truncated",
]
