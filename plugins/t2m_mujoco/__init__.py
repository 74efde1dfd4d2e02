"""MuJoCo backend of t2m: the TableEnv world simulated with MuJoCo (``--sim mujoco``)."""
