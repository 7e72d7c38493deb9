"""Load this checkout as the add-on package ``deformrt`` in a bpy session (for benchmarks that
build sample scenes), the way ``python . <command>`` does."""

import atexit
import importlib.util
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def load_package():
    if "deformrt" not in sys.modules:
        spec = importlib.util.spec_from_file_location("deformrt", ROOT / "__init__.py",
                                                      submodule_search_locations=[str(ROOT)])
        pkg = importlib.util.module_from_spec(spec)
        sys.modules["deformrt"] = pkg
        spec.loader.exec_module(pkg)
        pkg.register()
        # bpy crashes on exit with the add-on's classes still registered
        atexit.register(pkg.unregister)
    return sys.modules["deformrt"]
