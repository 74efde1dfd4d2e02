"""The PyBullet backend of t2m (``--sim pybullet``): the TableEnv world in the original's physics engine."""
