"""A Q-ensemble that also reads the primitive's geometric screen (docs/guide/skills.md#geometric-q-ensemble).

The published ensemble must learn from the 96 state numbers alone that an open finger comes down on
the hook lying beside a box: its data hold few such picks, and the shipped Pick ensemble calls about
half of its validation collisions successes. The domain's geometry already predicts them
(:func:`~t2m_skills_tableenv.geometric_screen.screen_values`), so :class:`GeometricQEnsemble` gives
each member that prediction as one more input and lets it learn how far to trust it.
"""

from __future__ import annotations

import torch

from t2m_core.domain.observation import FEATURES, OBSERVATION_ROWS, unnormalize
from t2m_skills_tableenv.networks import ENSEMBLE_SIZE, HIDDEN, QEnsemble


class GeometricQEnsemble(QEnsemble):
    """``members`` MLPs ``(96 + 4 + F) → 256 → 256 → 1``: :class:`QEnsemble` with the skill's F
    geometric screen predictions (:data:`~t2m_skills_tableenv.geometric_screen.SCREEN_FEATURES`) as
    more inputs.

    ``forward(states (N, 96), actions (N, 4), screen=None)`` returns the logits ``(N, B)``;
    ``screen`` ``(N, F)``, the inputs :meth:`screen` computes (flags ±0.5, margins scaled into
    [−0.5, 0.5]: :func:`~t2m_skills_tableenv.geometric_screen.screen_inputs`), is computed from the
    states and actions when not given (a trainer passes those of its dataset, computed once).
    Member-specific ``(B, N, 96)`` and ``(B, N, 4)`` inputs take a ``(B, N, F)`` screen. The screen
    is computed outside autograd: the actor's gradient does not see it, a search over actions does.
    """

    def __init__(
        self, skill: str, members: int = ENSEMBLE_SIZE, hidden: tuple[int, ...] = HIDDEN, features: tuple[str, ...] | None = None
    ) -> None:
        from t2m_skills_tableenv.geometric_screen import screen_features

        features = screen_features(skill, features)
        super().__init__(members=members, hidden=hidden, extra_inputs=len(features))
        self.skill, self.features = skill, features

    def screen(self, states: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        """``(..., F)`` the network inputs of the geometric screen of normalised ``states (..., 96)``
        and ``actions (..., 4)``, in [−0.5, 0.5], the dtype of ``states``."""
        from t2m_skills_tableenv.geometric_screen import screen_inputs, screen_values

        rows = unnormalize(states.detach().cpu().numpy().reshape(-1, OBSERVATION_ROWS, FEATURES))
        values = screen_values(self.skill, rows, actions.detach().cpu().numpy().reshape(len(rows), -1), self.features)
        inputs = torch.from_numpy(screen_inputs(values, self.features))
        return inputs.reshape(*states.shape[:-1], len(self.features)).to(device=states.device, dtype=states.dtype)

    def forward(self, states: torch.Tensor, actions: torch.Tensor, screen: torch.Tensor | None = None) -> torch.Tensor:
        if screen is None:
            screen = self.screen(states, actions)
        return self._logits(torch.cat((states, actions, screen.to(states.dtype)), dim=-1))
