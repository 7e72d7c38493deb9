"""DeformRT's command line (``blender -b --command deformrt ...``, ``python . ...``): info, the
demo on a bundled scene with its metrics table, every sample scene, the jellyfish job."""
