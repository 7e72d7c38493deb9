"""The repository root is also importable as the package ``deformrt`` (as Blender loads it),
so modules with package-relative imports (sample_scenes.fitting) load without Blender."""

import importlib.util
import sys
from pathlib import Path

_root = Path(__file__).resolve().parents[1]
if "deformrt" not in sys.modules:
    _spec = importlib.util.spec_from_file_location("deformrt", _root / "__init__.py",
                                                   submodule_search_locations=[str(_root)])
    _pkg = importlib.util.module_from_spec(_spec)
    sys.modules["deformrt"] = _pkg
    _spec.loader.exec_module(_pkg)
