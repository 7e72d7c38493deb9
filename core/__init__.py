"""DeformRT's algorithms: numpy, scipy, trimesh and embreex only, never bpy.

Loadable on its own (``import core`` with the extension root on the path, or as
``<extension>.core`` inside Blender) so pipelines and tests can use it without Blender.
"""

__version__ = "0.1.0"
