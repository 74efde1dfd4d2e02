"""t2m plugin: the ``scene-file`` scene parser, for robots without a camera pipeline.

Measure where the objects are, write them into a YAML or JSON file, and select it in a run
configuration: ``--set scene_parser.name=scene-file --set scene_parser.options.path=my_scene.yaml``.
"""

__version__ = "0.1.0"
