"""Makes ``t2m_scene_file`` importable when the tests run from a source checkout without installing it."""
