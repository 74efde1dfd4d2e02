"""t2m: language instructions to geometrically verified robot plans (Text2Motion as a framework).

The core package holds everything that is the same for every backend: protocols, hook specifications,
the plugin registry, the TableEnv domain, the task suite, prompts, configuration and the CLI.
Importing it is cheap: no torch, mujoco, pybullet, llama_cpp or litellm.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("text2motion")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.0.0+unknown"

__all__ = ["__version__"]
