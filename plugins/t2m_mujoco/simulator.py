"""The MuJoCo implementation of :class:`t2m_core.protocols.Simulator`.

Reset follows tableenv.md §8.1: the domain samples a candidate (its own analytic rejections
included), the backend drops the objects from 5 cm, moves the robot to the sampled random pose,
settles for 1-60 ticks and re-checks every initial proposition; a physical rejection moves on to the
next seed. ``execute`` runs the domain's motion steps (:mod:`t2m_mujoco.executor`) and applies the
domain's disturbance test, mid-sequence checks and post-conditions, exactly as the execution
contract of :mod:`t2m_core.domain.primitives.base` describes.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from t2m_mujoco.rendering import prefer_headless_gl

prefer_headless_gl()

from t2m_core.domain.geometry import is_above, object_geometry  # noqa: E402
from t2m_core.domain.objects import ObjectKind, object_spec  # noqa: E402
from t2m_core.domain.observation import encode_observation  # noqa: E402
from t2m_core.domain.predicates import Proposition, canonical_order, holds_all  # noqa: E402
from t2m_core.domain.primitives import (  # noqa: E402
    MotionKind,
    MotionStep,
    Outcome,
    StepContext,
    first_disturbed,
    get_primitive,
)
from t2m_core.domain.sampling import SampledScene, SamplingError, sample_initial_state  # noqa: E402
from t2m_core.domain.state import GeometricState  # noqa: E402
from t2m_core.protocols import Contact, PrimitiveResult, ResetResult  # noqa: E402
from t2m_mujoco.executor import Executor  # noqa: E402
from t2m_mujoco.options import MujocoOptions  # noqa: E402
from t2m_mujoco.rendering import CameraRenderer  # noqa: E402
from t2m_mujoco.scene import build_scene  # noqa: E402
from t2m_mujoco.world import Snapshot, World  # noqa: E402

RESET_SETTLE_MAX_TICKS = 60
"""§8.1 step 5: settle at most 1 s; needing all of it rejects the seed."""
RESET_HOLD_TICKS = 10
"""Ticks that close the fingers on an object put in hand by the sampler (§8.3, non-realistic grasp)."""


class MujocoSimulator:
    """TableEnv in MuJoCo (``--sim mujoco``).

    Args:
        options: validated :class:`MujocoOptions` (``None``: the defaults).

    Attributes:
        reset_stats: after each reset, ``{"sampler_rejections", "physics_rejections", "reasons"}``.
    """

    def __init__(self, options: MujocoOptions | None = None) -> None:
        self.options = options if options is not None else MujocoOptions()
        self.world: World | None = None
        self.executor: Executor | None = None
        self.task: Any = None
        self.reset_stats: dict[str, Any] = {}
        self._renderer: CameraRenderer | None = None
        self._frames: list[np.ndarray] = []
        self._frame_sink: Callable[[np.ndarray], None] | None = None

    # --- scene ------------------------------------------------------------------------------------

    def _load(self, object_names: tuple[str, ...]) -> World:
        if self.world is None or self.world.scene.object_names != object_names:
            if self._renderer is not None:
                self._renderer.close()
                self._renderer = None
            scene = build_scene(object_names, self.options.timestep)
            self.world = World(scene, self.options.substeps)
            frame_every = max(1, round(60 / self.options.video_fps))
            self.executor = Executor(self.world, on_tick=self._on_tick, frame_every=frame_every)
        return self.world

    def _require_world(self) -> World:
        if self.world is None:
            raise RuntimeError("the simulator has no scene yet: call reset(task, seed=...) first")
        return self.world

    # --- reset ------------------------------------------------------------------------------------

    def reset(self, task: Any, *, seed: int) -> ResetResult:
        """Sample, settle and verify ``task``'s initial state from ``seed`` (tableenv.md §8.1).

        Raises:
            SamplingError: no candidate seed was accepted within ``max_reset_attempts``.
        """
        names = tuple(task.objects)
        propositions = canonical_order(task.initial_state)
        world = self._load(names)
        self.task = task
        candidate = int(seed)
        sampler_rejections = 0
        reasons: Counter[str] = Counter()
        for _ in range(self.options.max_reset_attempts):
            sampled = sample_initial_state(names, propositions, candidate)
            sampler_rejections += sampled.rejections
            reason = self._realise(sampled, propositions)
            if reason is None:
                self.reset_stats = {
                    "sampler_rejections": sampler_rejections,
                    "physics_rejections": sum(reasons.values()),
                    "reasons": dict(reasons),
                }
                world.ticks = 0
                world.canonicalize()
                state = world.geometric_state()
                return ResetResult(
                    state=state,
                    observation=encode_observation(state, names),
                    accepted_seed=sampled.accepted_seed,
                    rejections=sampler_rejections + sum(reasons.values()),
                )
            reasons[reason] += 1
            candidate = sampled.accepted_seed + 1
        raise SamplingError(
            f"no initial state of {getattr(task, 'id', names)} survived physics in {self.options.max_reset_attempts} "
            f"candidates from seed {seed}; rejections: {dict(reasons)}",
            "raise max_reset_attempts, or check the task's initial state",
        )

    def _realise(self, sampled: SampledScene, propositions: Sequence[Proposition]) -> str | None:
        """Load a sampled candidate into physics; ``None`` if it survives, else the rejection reason."""
        world, executor = self.world, self.executor
        assert world is not None and executor is not None
        world.reset_robot()
        drop = sampled.drop_state
        for name in world.scene.free_names:
            world.set_object_pose(name, drop.objects[name])
        world.forward()
        held = drop.held
        if held is not None:
            # Non-realistic grasp (§3.3): weld first, then close the fingers onto the object.
            world.attach(held)
            world.set_gripper(0.0)
            world.tick(RESET_HOLD_TICKS)
            world.set_gripper(world.finger_q())
            if _touches_arm(world, held):
                return "held_object_touches_robot"
        move = MotionStep(MotionKind.MOVE, "random_pose", sampled.robot_pose.position, sampled.robot_pose.yaw)
        executor.begin_primitive()
        if executor.run(move).failure is not None:
            return "robot_pose_unreachable"
        if executor.settle(RESET_SETTLE_MAX_TICKS / 60.0) >= RESET_SETTLE_MAX_TICKS:
            return "did_not_settle"
        state = world.geometric_state()
        for name in world.scene.free_names:
            if state.objects[name].position[2] < 0.0:
                return "below_table"
        base = world.scene.robot.base_body
        base_geoms = np.flatnonzero(world.model.geom_bodyid == base)
        object_owners = [world.scene.owners.index(n) for n in world.scene.free_names]
        if world.contacts_between(base_geoms, object_owners):
            return "touches_robot_base"
        for prop in propositions:
            if prop.predicate == "on" and object_spec(prop.args[1]).kind is not ObjectKind.TABLE:
                child, parent = prop.args
                if not is_above(object_geometry(child, state.objects[child]), object_geometry(parent, state.objects[parent])):
                    return "fell_off_support"
        if not holds_all(propositions, state):
            return "propositions_failed"
        return None

    # --- execution --------------------------------------------------------------------------------

    def execute(self, primitive: str, arguments: Sequence[str], action: np.ndarray) -> PrimitiveResult:
        """Run one primitive with a normalised ``(4,)`` action in ``[-1, 1]`` (tableenv.md §10).

        Raises:
            KeyError: unknown primitive. ValueError: bad arguments or action.
        """
        world = self._require_world()
        executor = self.executor
        assert executor is not None
        spec = get_primitive(primitive)
        action = _checked_action(action, spec.action_dim)
        start = world.geometric_state()
        arguments = spec.check_arguments(start, arguments)
        self._frames = []
        world.canonicalize()
        executor.begin_primitive()
        contacts: list[Contact] = []
        reason = spec.precheck(start, arguments, action)
        if reason is None:
            for step in spec.motion(start, arguments, action):
                report = executor.run(step)
                contacts.extend(report.contacts)
                reason = report.failure
                if reason is None:
                    now = world.geometric_state()
                    reason = first_disturbed(start, now, step.disturbance_objects)
                    if reason is None and step.check is not None:
                        reason = step.check(StepContext(start, now, arguments, world.distance))
                if reason is not None:
                    break
        end = world.geometric_state()
        outcome = Outcome.failed(reason) if reason is not None else spec.outcome(start, end, arguments)
        frames, self._frames = self._frames, []
        return PrimitiveResult(
            success=outcome.success,
            truncated=outcome.truncated,
            failure=outcome.failure,
            state=end,
            observation=encode_observation(end, world.scene.object_names),
            contacts=tuple(contacts),
            frames=tuple(frames),
        )

    # --- state ------------------------------------------------------------------------------------

    def get_state(self) -> Snapshot:
        """Exact snapshot: MuJoCo integration state (incl. warm start and sleep), weld, controller."""
        return self._require_world().snapshot()

    def set_state(self, snapshot: Snapshot) -> None:
        self._require_world().restore(snapshot)

    def geometric_state(self) -> GeometricState:
        return self._require_world().geometric_state()

    def observation(self) -> np.ndarray:
        world = self._require_world()
        return encode_observation(world.geometric_state(), world.scene.object_names)

    # --- rendering --------------------------------------------------------------------------------

    def _camera_renderer(self) -> CameraRenderer:
        world = self._require_world()
        if self._renderer is None:
            self._renderer = CameraRenderer(world.model, self.options.render_width, self.options.render_height)
        return self._renderer

    def render(self, camera: str | None = None, *, depth: bool = False) -> np.ndarray:
        """``(H, W, 3) uint8`` RGB or ``(H, W) float32`` depth (metres) from a named camera
        (``front``, ``side``, ``top``; default from the options)."""
        renderer = self._camera_renderer()
        name = camera or self.options.camera
        data = self._require_world().data
        return renderer.depth(data, name) if depth else renderer.rgb(data, name)

    def camera_intrinsics(self, camera: str | None = None) -> np.ndarray:
        """``(3, 3)`` pinhole matrix of a camera at the render size."""
        return self._camera_renderer().intrinsics(camera or self.options.camera)

    def stream_frames(self, sink: Callable[[np.ndarray], None] | None) -> None:
        """Send every recorded frame to ``sink`` (e.g. :meth:`t2m_core.video.VideoWriter.add`) as it is
        rendered, instead of collecting them in the results; ``None`` stops streaming."""
        self._frame_sink = sink

    def _on_tick(self, world: World) -> None:
        if self._frame_sink is None and not self.options.record_video:
            return
        frame = self.render()
        if self._frame_sink is not None:
            self._frame_sink(frame)
        else:
            self._frames.append(frame)

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
        self.world = None
        self.executor = None


def _checked_action(action: np.ndarray, dim: int) -> np.ndarray:
    array = np.asarray(action, dtype=np.float64)
    if array.shape != (dim,):
        raise ValueError(f"action must have shape ({dim},), got {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"action must be finite, got {array}")
    if np.any(np.abs(array) > 1.0 + 1e-6):
        raise ValueError(f"action must be normalised to [-1, 1], got {array}")
    return np.clip(array, -1.0, 1.0)


def _touches_arm(world: World, held: str) -> bool:
    """Whether the held object touches a robot part other than the fingers (§8.3 step 4)."""
    fingers = {world.model.body("panda_leftfinger").id, world.model.body("panda_rightfinger").id}
    data = world.data
    owner_robot = world.scene.owners.index("robot")
    held_geoms = set(world.geoms_of(held).tolist())
    for i in range(data.ncon):
        g1, g2 = int(data.contact.geom[i][0]), int(data.contact.geom[i][1])
        other = g2 if g1 in held_geoms else g1 if g2 in held_geoms else None
        if other is None or world.scene.geom_owner[other] != owner_robot:
            continue
        if world.model.geom_bodyid[other] not in fingers:
            return True
    return False
