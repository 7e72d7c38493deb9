"""One pass through DeformRT as a user of one Blender version meets it, run by that Blender's Python
(``python blender_smoke.py <extension zip>``; test_blender_versions.py runs it for each version):
install the zip the way Preferences > Get Extensions does, register, resolve and inspect the tubes
with a Subdivision on each garment, render in Cycles and in DeformRT Layered, bake frames to
Alembic, add and bake a jellyfish, unregister. Prints one ``step: ok`` line per step, then ``done``;
anything else is a failure, and so is any exit code but 0 (a crash on the way out included)."""

import atexit
import json
import os
import shutil
import sys
import tempfile
from pathlib import Path

_user = tempfile.mkdtemp(prefix="deformrt-smoke-user-")
os.environ["BLENDER_USER_RESOURCES"] = _user
atexit.register(shutil.rmtree, _user, ignore_errors=True)  # the installed wheels, 150-400 MB

import bpy  # noqa: E402  (the user folder must be set before Blender loads)
import numpy as np  # noqa: E402

REPO = "deformrt_smoke"


def step(name):
    print(f"{name}: ok", flush=True)


def evaluated(obj):
    depsgraph = bpy.context.evaluated_depsgraph_get()
    ev = obj.evaluated_get(depsgraph)
    mesh = ev.to_mesh()
    co = np.empty(len(mesh.vertices) * 3)
    mesh.vertices.foreach_get("co", co)
    ev.to_mesh_clear()
    return co.reshape(-1, 3)


def render(engine, path, passes_expected=None):
    scene = bpy.context.scene
    scene.render.engine = engine
    scene.render.resolution_x, scene.render.resolution_y, scene.render.resolution_percentage = 64, 48, 100
    if engine == "CYCLES":
        scene.cycles.samples = 2
        scene.cycles.device = "CPU"
    scene.render.filepath = str(path)
    assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
    image = bpy.data.images.load(str(path))
    pixels = np.empty(image.size[0] * image.size[1] * image.channels, dtype=np.float32)
    image.pixels.foreach_get(pixels)
    lit = float(pixels.reshape(-1, image.channels)[:, :3].max())
    assert lit > 0.05, f"{engine} rendered a black image"


def main(zip_path: str) -> int:
    print(f"blender {bpy.app.version_string} python {sys.version.split()[0]} numpy {np.__version__}", flush=True)
    out = Path(tempfile.mkdtemp(prefix="deformrt-smoke-out-"))
    atexit.register(shutil.rmtree, out, ignore_errors=True)
    repo_dir = Path(_user) / "repo"
    repo_dir.mkdir()
    repo = bpy.context.preferences.extensions.repos.new(name="DeformRT Smoke", module=REPO,
                                                        custom_directory=str(repo_dir), source="USER")
    assert bpy.ops.extensions.package_install_files(repo=repo.module, filepath=zip_path,
                                                    enable_on_install=True) == {"FINISHED"}
    module = f"bl_ext.{REPO}.deformrt"
    assert module in bpy.context.preferences.addons, "installed but not enabled"
    ext = sys.modules[module]
    # every compiled wheel the zip bundles for this Blender's Python was installed and loads
    correspondence = __import__(f"{module}.core.layering.correspondence", fromlist=["_fcpw"])
    assert correspondence._fcpw is not None, "fcpw's wheel was not installed: the exact body search is off"
    import embreex.rtcore_scene  # noqa: F401
    step("install and register")

    bpy.ops.wm.read_homefile(use_empty=True)
    tubes = __import__(f"{module}.sample_scenes.tubes", fromlist=["build"])
    body, (shirt, jacket) = tubes.build(seed=0, resolution=32)
    for g in (shirt, jacket):
        mod = g.modifiers.new("Subdivision", "SUBSURF")
        mod.levels, mod.render_levels = 1, 2
    fitted = evaluated(shirt)
    assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
    assert not np.array_equal(evaluated(shirt)[: len(fitted)], fitted), "the resolve changed nothing"
    assert [m.name for m in shirt.modifiers] == ["DeformRT", "Subdivision"]
    step("resolve")
    assert bpy.ops.deformrt.inspect_layers() == {"FINISHED"}
    report = json.loads(bpy.context.scene.deformrt.last_report)
    assert report["crossings_after"] < report["crossings_before"], report["message"]
    step("inspect")
    render("CYCLES", out / "cycles.png")
    step("render cycles")
    render("DEFORMRT_LAYERED", out / "layered.png")
    step("render layered")
    bpy.context.scene.render.engine = "CYCLES"
    abc = out / "layers.abc"
    assert bpy.ops.deformrt.bake_frames(frame_start=1, frame_end=2, filepath=str(abc)) == {"FINISHED"}
    assert abc.is_file() and abc.stat().st_size > 0
    step("bake frames")
    assert bpy.ops.deformrt.clear_results() == {"FINISHED"}
    step("clear")

    bpy.ops.wm.read_homefile(use_empty=True)
    assert bpy.ops.deformrt.add_jellyfish(size=0.5, segments=16, tentacles=4, veins=2) == {"FINISHED"}
    assert bpy.ops.deformrt.bake_jellyfish(frame_start=1, frame_end=6, cycle_frames=6) == {"FINISHED"}
    bell = bpy.context.active_object
    assert bell.data.shape_keys is not None and len(bell.data.shape_keys.key_blocks) > 1
    step("jellyfish add and bake")

    bpy.ops.preferences.addon_disable(module=module)
    assert module not in bpy.context.preferences.addons
    del ext
    step("unregister")
    print("done", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
