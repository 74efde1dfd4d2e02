"""The learned TableEnv skill library: Q-ensembles, policies and dynamics for pick, place, pull and
push, their training and OOD calibration, and the checkpoints shipped with t2m
(docs/guide/skills.md)."""
