from t2m_core.testing import check_import_light
from t2m_pybullet.hooks import t2m_register_simulators


def test_hooks_register_pybullet_lazily():
    (spec,) = t2m_register_simulators()
    assert spec.name == "pybullet" and spec.factory == "t2m_pybullet.simulator:PybulletSimulator"
    options = spec.options.model_validate({"substeps": 8})
    assert abs(options.timestep - 1 / 480) < 1e-12
    check_import_light("t2m_pybullet.hooks")
