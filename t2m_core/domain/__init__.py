"""The TableEnv world, independent of any physics engine: objects, zones, geometry, predicates,
goals, the observation encoding, skills' symbolic side, primitive specifications and initial-state
sampling. Pure Python + NumPy; every backend executes what is decided here."""
