"""Run DeformRT's command line from a plain Python that has the bpy module.

    python path/to/deformrt info
    python path/to/deformrt demo --out out/demo

The same commands run inside Blender as ``blender -b --command deformrt ...``.
"""

import importlib.util
import sys
from pathlib import Path

_root = Path(__file__).resolve().parent
# Load this folder as the package "deformrt" so its relative imports work as they do in Blender.
_spec = importlib.util.spec_from_file_location(
    "deformrt", _root / "__init__.py", submodule_search_locations=[str(_root)]
)
_pkg = importlib.util.module_from_spec(_spec)
sys.modules["deformrt"] = _pkg
_spec.loader.exec_module(_pkg)
_pkg.register()
try:
    from deformrt.sample_scenes.cli import commands

    code = commands.main(sys.argv[1:])
finally:
    _pkg.unregister()
sys.exit(code)
