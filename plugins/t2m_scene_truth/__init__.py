"""Builtin plugin: the ``ground-truth`` scene parser (the simulator's own geometric state)."""
