"""Test-session settings shared by every test."""

from hypothesis import settings

# Property tests judge values, never speed: a per-example deadline only makes them fail on a loaded
# machine (speed is measured by the scripts in benchmarks/).
settings.register_profile("t2m", deadline=None)
settings.load_profile("t2m")
