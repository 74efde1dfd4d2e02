"""t2m: language instructions to geometrically verified robot plans (Text2Motion as a framework).

The core package holds everything that is the same for every backend: protocols, hook specifications,
the plugin registry, the TableEnv domain, the task suite, prompts, configuration and the CLI.
Importing it is cheap: no torch, mujoco, pybullet, llama_cpp or litellm.
"""

__all__ = ["__version__"]


def __getattr__(name: str) -> str:
    # looked up on first use: importlib.metadata costs ~0.1 s, which `t2m --help` need not pay
    if name != "__version__":
        raise AttributeError(f"module 't2m_core' has no attribute {name!r}")
    from importlib.metadata import PackageNotFoundError, version

    try:
        value = version("text2motion")
    except PackageNotFoundError:  # running from a source tree that is not installed
        value = "0.0.0+unknown"
    globals()["__version__"] = value
    return value
