"""What every physics backend of the TableEnv world shares (docs/guide/simulators.md).

A backend implements :class:`~t2m_core.simulation.backend.PhysicsBackend`: time in 1/60 s ticks,
the arm's servo targets and IK, the gripper, object poses and twists, contacts, the grasp weld.
Everything else is driven from here, the same for every engine: the motion rules of each
:class:`~t2m_core.domain.primitives.MotionStep` (:mod:`~t2m_core.simulation.motion`), one primitive
execution (:mod:`~t2m_core.simulation.execution`), the sample-settle-verify reset
(:mod:`~t2m_core.simulation.reset`), the grasp test (:mod:`~t2m_core.simulation.grasp`), and the
facts both engines build from: the Panda as TableEnv mounts it (:mod:`~t2m_core.simulation.robot`),
contact frictions and cameras (:mod:`~t2m_core.simulation.scene`).

Nothing here imports an engine.
"""
