"""Dynamics that correct the primitives' own geometry (docs/guide/skills.md#geometric-prior).

:class:`PriorDynamics` predicts the next state as the geometric prior
(:func:`~t2m_skills_tableenv.geometric_prior.prior_next_rows`) plus a learned correction of the
context rows (the EE's and the skill's arguments'), read either as encoded (``frame="world"``) or in
the polar frame at the moved object (``frame="target"``, Pull and Push), where a sweep's physics does
not depend on where on the table it happens.
"""

from __future__ import annotations

import torch
from torch import nn

from t2m_core.domain.observation import FEATURE_HIGH, FEATURE_LOW, OBSERVATION_ROWS, normalize, unnormalize
from t2m_core.domain.observation import FEATURES as ROW_FEATURES
from t2m_skills_tableenv.networks import ACTION_DIM, HIDDEN, STATE_DIM, _weights, mlp

YAW_FEATURE = 5
"""A row's rotation-vector z: the yaw of an upright object, radians before normalisation."""
FRAMES = ("world", "target")
HUBER_DELTA = 0.002
"""Encoded error (2.4 mm in x, 2 mm in y, 0.7° of yaw) above which the loss grows linearly: a swept
box's end scatters with the contact (docs/guide/skills.md#geometric-prior), and a squared loss lets
the few far outcomes pull every prediction towards them; a linear one predicts the typical outcome."""
_SCALE = torch.from_numpy(FEATURE_HIGH - FEATURE_LOW)
_MIDDLE = torch.from_numpy(0.5 * (FEATURE_HIGH + FEATURE_LOW))
_FRAMED_FEATURES = 13
"""Per context row in the target frame: x, y relative to the moved object, z, sin and cos of the yaw
relative to the frame, the rotation vector's x and y, and the six shape features (encoded)."""
_FRAMED_OUTPUT = 4
"""Per context row in the target frame: corrections of x, y, z (metres) and yaw (radians)."""


class PriorDynamics(nn.Module):
    """ŝ′ = p + correction, ``p`` the primitive's geometric prediction of the next state.

    ``p`` (:func:`~t2m_skills_tableenv.geometric_prior.prior_next_rows`: the carried object, the EE
    and the hook exactly, a swept box moved with the hook's head) is encoded like the states. An MLP
    (two hidden layers of 256) corrects the ``context_rows`` rows of the EE and the skill's arguments
    from those rows before and as predicted, and the action:

    - ``frame="world"``: reads and corrects the encoded rows as they are;
    - ``frame="target"``: reads positions and yaws in the polar frame at the moved object (origin at
      its xy, x pointing away from the robot's base: the frame of a Pull's or Push's action) and
      corrects each context row's position and yaw in that frame.

    The other objects are the prior's, unchanged: a skill that moves a bystander has failed
    (``disturbed``), and the dynamics model only successes. The output layer starts at zero, so an
    untrained network predicts the prior. The prior is computed in float64 numpy and is not
    differentiated through (planning never needs gradients of the dynamics).
    ``forward(states (N, 96), actions (N, 4)) -> (N, 96)``, like the other dynamics networks.
    """

    def __init__(self, skill: str, context_rows: int, frame: str = "world", hidden: tuple[int, ...] = HIDDEN) -> None:
        super().__init__()
        from t2m_skills_tableenv.geometric_prior import PRIOR_SKILLS

        if skill not in PRIOR_SKILLS:
            raise ValueError(f"no geometric prior for skill {skill!r} (known: {', '.join(PRIOR_SKILLS)})")
        if not 1 <= context_rows < OBSERVATION_ROWS:
            raise ValueError(f"context_rows must be in [1, {OBSERVATION_ROWS - 1}], got {context_rows}")
        if frame not in FRAMES:
            raise ValueError(f"unknown frame {frame!r} (known: {', '.join(FRAMES)})")
        self.skill, self.rows, self.frame = skill, context_rows, frame
        self.context = context_rows * ROW_FEATURES
        per_row_in, per_row_out = (ROW_FEATURES, ROW_FEATURES) if frame == "world" else (_FRAMED_FEATURES, _FRAMED_OUTPUT)
        self.net = mlp((2 * context_rows * per_row_in + ACTION_DIM, *hidden, context_rows * per_row_out))
        nn.init.zeros_(self.net[-1].weight)

    def prior(self, states: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        """``(N, 96)`` the encoded geometric prediction for normalised ``states`` and ``actions``."""
        from t2m_skills_tableenv.geometric_prior import prior_next_rows

        rows = unnormalize(states.detach().cpu().numpy().reshape(-1, OBSERVATION_ROWS, ROW_FEATURES))
        predicted = normalize(prior_next_rows(self.skill, rows, actions.detach().cpu().numpy()))
        return torch.from_numpy(predicted.reshape(-1, STATE_DIM)).to(device=states.device, dtype=states.dtype)

    def forward(self, states: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        prior = self.prior(states, actions)
        count = states.shape[0]
        before = states[:, : self.context].reshape(count, self.rows, ROW_FEATURES)
        predicted = prior[:, : self.context].reshape(count, self.rows, ROW_FEATURES)
        corrected = self._world(before, predicted, actions) if self.frame == "world" else self._target(before, predicted, actions)
        # a corrected yaw beyond ±π is the same turn: back into the encoding's range
        corrected = _with_yaw(corrected, wrapped_yaw(corrected[..., YAW_FEATURE]))
        return torch.cat((corrected.reshape(count, -1), prior[:, self.context :]), dim=-1)

    def _world(self, before: torch.Tensor, predicted: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        count = before.shape[0]
        inputs = torch.cat((before.reshape(count, -1), 0.5 * actions, (predicted - before).reshape(count, -1)), dim=-1)
        return predicted + self.net(inputs).reshape(predicted.shape)

    def _target(self, before: torch.Tensor, predicted: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        count = before.shape[0]
        raw_before, raw_predicted = _raw(before), _raw(predicted)
        origin = raw_before[:, 1, :2]  # (N, 2) the moved object's xy
        phi = torch.atan2(origin[:, 1], origin[:, 0])
        inputs = torch.cat((_framed(before, raw_before, origin, phi), 0.5 * actions, _framed(predicted, raw_predicted, origin, phi)), dim=-1)
        correction = self.net(inputs).reshape(count, self.rows, _FRAMED_OUTPUT)
        cos, sin = torch.cos(phi)[:, None], torch.sin(phi)[:, None]
        dx, dy = correction[..., 0], correction[..., 1]
        raw = raw_predicted.clone()
        raw[..., 0] = raw[..., 0] + cos * dx - sin * dy
        raw[..., 1] = raw[..., 1] + sin * dx + cos * dy
        raw[..., 2] = raw[..., 2] + correction[..., 2]
        raw[..., YAW_FEATURE] = raw[..., YAW_FEATURE] + correction[..., 3]
        encoded = (raw - _MIDDLE.to(raw)) / _SCALE.to(raw)
        # only position and yaw are corrected; the other features stay the prior's exactly
        kept = torch.zeros(ROW_FEATURES, dtype=torch.bool)
        kept[[0, 1, 2, YAW_FEATURE]] = True
        return torch.where(kept.to(raw.device), encoded, predicted)

    @staticmethod
    def loss(predicted: torch.Tensor, targets: torch.Tensor) -> torch.Tensor:
        """Huber loss (:data:`HUBER_DELTA`) of ``(N, 96)`` encoded states against the recorded next
        states, with each row's yaw (the rotation vector's z, feature 5) compared modulo a full turn:
        an upright object at +179° and one at −179° are 2° apart, not 358° (the rotation vector of a
        yaw jumps at ±π; in 4–11 % of the successful transitions the recorded next yaw of the moved
        object or the EE lies across that jump from the prior's)."""
        difference = (predicted - targets).reshape(predicted.shape[0], -1, ROW_FEATURES)
        difference = _with_yaw(difference, wrapped_yaw(difference[..., YAW_FEATURE]))
        return nn.functional.huber_loss(difference, torch.zeros_like(difference), delta=HUBER_DELTA)

    def flops_per_sample(self) -> int:
        """Floating-point operations (2 × multiply-adds) of the network for one (state, action); the
        prior's geometry is not counted."""
        return 2 * sum(_weights(self.net))


def wrapped_yaw(normalised: torch.Tensor) -> torch.Tensor:
    """Normalised yaws (a full turn is 1.0 after :func:`~t2m_core.domain.observation.normalize`)
    wrapped into [−0.5, 0.5)."""
    return normalised - torch.floor(normalised + 0.5)


def _with_yaw(rows: torch.Tensor, yaw: torch.Tensor) -> torch.Tensor:
    """``rows (..., 12)`` with feature 5 replaced by ``yaw (...)``, without writing in place."""
    return torch.cat((rows[..., :YAW_FEATURE], yaw[..., None], rows[..., YAW_FEATURE + 1 :]), dim=-1)


def _raw(rows: torch.Tensor) -> torch.Tensor:
    """Encoded ``(..., 12)`` rows back in metres and radians."""
    return rows * _SCALE.to(rows) + _MIDDLE.to(rows)


def _framed(rows: torch.Tensor, raw: torch.Tensor, origin: torch.Tensor, phi: torch.Tensor) -> torch.Tensor:
    """``(N, C·13)`` context rows in the polar frame at ``origin (N, 2)`` turned by ``phi (N,)``."""
    cos, sin = torch.cos(phi)[:, None], torch.sin(phi)[:, None]
    dx, dy = raw[..., 0] - origin[:, None, 0], raw[..., 1] - origin[:, None, 1]
    yaw = raw[..., YAW_FEATURE] - phi[:, None]
    features = torch.stack((cos * dx + sin * dy, -sin * dx + cos * dy, raw[..., 2], torch.sin(yaw), torch.cos(yaw)), dim=-1)
    return torch.cat((features, rows[..., 3:5], rows[..., 6:]), dim=-1).reshape(rows.shape[0], -1)
