"""Add-on tests run in a bpy session against the built extension zip, installed the way
Blender installs it (a temporary user repository, Blender's own install operator).

The user resource folder points at a temporary directory before bpy loads, so the
tests never touch the developer's Blender configuration; it goes when the session ends.
"""

import atexit
import importlib
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
_USER = tempfile.mkdtemp(prefix="deformrt-blender-user-")
os.environ["BLENDER_USER_RESOURCES"] = _USER
# the installed extension copies its bundled wheels here (about 400 MB a session): left behind,
# a few dozen runs fill the disk
atexit.register(shutil.rmtree, _USER, ignore_errors=True)

bpy = pytest.importorskip("bpy")

REPO_MODULE = "deformrt_test"


def _platform_tag() -> str:
    machine = platform.machine().lower()
    arch = "arm64" if machine in {"arm64", "aarch64"} else "x64"
    system = {"linux": "linux", "darwin": "macos", "win32": "windows"}[sys.platform]
    return f"{system}_{arch}"


def _sources_newer_than(path: Path) -> bool:
    stamp = path.stat().st_mtime
    for folder in ("core", "addon", "operators", "sample_scenes"):
        if any(p.stat().st_mtime > stamp for p in (ROOT / folder).rglob("*.py")):
            return True
    return any((ROOT / f).stat().st_mtime > stamp for f in ("__init__.py", "__main__.py", "blender_manifest.toml"))


def built_zip() -> Path:
    manifest = tomllib.loads((ROOT / "blender_manifest.toml").read_text())
    zip_path = ROOT / "dist" / f"{manifest['id']}-{manifest['version']}-{_platform_tag()}.zip"
    if not zip_path.is_file() or _sources_newer_than(zip_path):
        subprocess.run([sys.executable, str(ROOT / ".ci" / "build.py")], check=True)
    return zip_path


@pytest.fixture(scope="session")
def extension_zip() -> Path:
    """This platform's extension zip, built from the sources when they are newer."""
    return built_zip()


@pytest.fixture(scope="session")
def extension():
    """The installed extension's package (``bl_ext.deformrt_test.deformrt``)."""
    zip_path = built_zip()
    repo_dir = Path(_USER) / "repo"
    repo_dir.mkdir(exist_ok=True)
    repos = bpy.context.preferences.extensions.repos
    repo = repos.new(name="DeformRT Test", module=REPO_MODULE, custom_directory=str(repo_dir), source="USER")
    result = bpy.ops.extensions.package_install_files(repo=repo.module, filepath=str(zip_path), enable_on_install=True)
    assert result == {"FINISHED"}, f"installing {zip_path.name} failed: {result}"
    module = f"bl_ext.{REPO_MODULE}.deformrt"
    assert module in bpy.context.preferences.addons, "the extension installed but is not enabled"
    yield sys.modules[module]
    # what the session registered and made goes again: Blender reports no unfreed memory at exit
    bpy.ops.preferences.addon_disable(module=module)
    bpy.ops.wm.read_homefile(use_empty=True)


@pytest.fixture
def clean_scene(extension):
    """A fresh empty file for each test (preferences and the enabled extension stay)."""
    bpy.ops.wm.read_homefile(use_empty=True)
    return bpy.context.scene


@pytest.fixture(scope="session")
def dressed_figure(extension):
    """``dressed_figure(name)``: the dressed figure ``name`` of sample_scenes.dressed (seed 0) in a
    fresh file, as (body, rig, garments). Built once a session (a cloth drape, 20-60 s) and saved;
    opened from that copy after (the builder's own determinism is tested in test_scenes)."""
    saved = {}

    def build(name):
        if name not in saved:
            bpy.ops.wm.read_homefile(use_empty=True)
            body, rig, garments = getattr(importlib.import_module(f"{extension.__name__}.sample_scenes.dressed"),
                                          name)()
            path = Path(_USER) / f"{name}.blend"
            bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)
            saved[name] = (path, body.name, rig.name if rig is not None else None, [g.name for g in garments])
            return body, rig, garments
        path, body, rig, garments = saved[name]
        bpy.ops.wm.open_mainfile(filepath=str(path))
        objects = bpy.data.objects
        return objects[body], objects[rig] if rig is not None else None, [objects[g] for g in garments]

    return build
