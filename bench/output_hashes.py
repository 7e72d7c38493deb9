"""Hashes of what DeformRT makes, through its public entry points only (the bundled scenes, the
operators, the render engine by its bl_idname, core.layering.resolve_layers, core.jellyfish), so a
restructure can show its outputs are bit-identical: run it before and after and compare.

    .venv/bin/python -m bench.output_hashes          # ~3 min; prints one line per output
"""

import hashlib
import importlib
import tempfile
from pathlib import Path

import numpy as np

from bench.blender import load_package


def digest(*arrays) -> str:
    h = hashlib.sha256()
    for a in arrays:
        a = np.ascontiguousarray(a)
        h.update(str((a.dtype, a.shape)).encode())
        h.update(a.tobytes())
    return h.hexdigest()[:16]


def evaluated(bpy, obj):
    """World vertices (float32 as Blender holds them) and triangles, read with plain bpy."""
    ev = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    mesh = ev.to_mesh()
    try:
        mesh.calc_loop_triangles()
        co = np.empty(len(mesh.vertices) * 3, np.float32)
        mesh.vertices.foreach_get("co", co)
        tris = np.empty(len(mesh.loop_triangles) * 3, np.int32)
        mesh.loop_triangles.foreach_get("vertices", tris)
        parts = mesh.attributes.get("deformrt_part_s5")
        seg = None
        if parts is not None:
            seg = np.empty(len(mesh.vertices), np.int32)
            parts.data.foreach_get("value", seg)
    finally:
        ev.to_mesh_clear()
    mw = np.array(obj.matrix_world, np.float64)
    return co.reshape(-1, 3).astype(np.float64) @ mw[:3, :3].T + mw[:3, 3], tris.reshape(-1, 3), seg


def tagged(bpy, scene):
    objs = [o for o in scene.objects if o.type == "MESH" and o.deformrt.role in ("BODY", "GARMENT")
            and not o.users_collection[0].name.startswith("DeformRT")]
    body = next(o for o in objs if o.deformrt.role == "BODY")
    garments = sorted((o for o in objs if o.deformrt.role == "GARMENT"), key=lambda o: o.deformrt.layer)
    return body, garments


def figures(out):
    import bpy
    import trimesh

    catalog = importlib.import_module("deformrt.sample_scenes.catalog")
    layering = importlib.import_module("deformrt.core.layering")
    for name in ("fig_4_12", "fig_4_13", "tubes"):
        catalog.SCENES[name][0](0)
        scene = bpy.context.scene
        body, garments = tagged(bpy, scene)
        inputs = [evaluated(bpy, o) for o in (body, *garments)]
        out(f"{name} inputs", digest(*[a for v, f, _ in inputs for a in (v, f)]))
        meshes = [trimesh.Trimesh(v, f, process=False, validate=False) for v, f, _ in inputs]
        seg = inputs[0][2]
        params = {"body_segments": seg, "scheme": "S5"} if seg is not None else {}
        res = layering.resolve_layers(meshes[0], meshes[1:], **params)
        out(f"{name} core resolve_layers", digest(*res.moved, *res.removed_faces))
        assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
        out(f"{name} operator, evaluated", digest(*[a for o in garments for a in evaluated(bpy, o)[:2]]))
        if name != "tubes":
            layered(bpy, scene, name, out)


def layered(bpy, scene, name, out):
    """DeformRT Layered render of the scene as fitted (the engine layers the tagged garments itself)."""
    assert bpy.ops.deformrt.clear_results() == {"FINISHED"}
    scene.render.engine = "DEFORMRT_LAYERED"
    scene.render.resolution_x = scene.render.resolution_y = 160
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = "OPEN_EXR"
    for mode in (True, False):
        scene.deformrt.render_layered = mode
        with tempfile.TemporaryDirectory() as folder:
            path = Path(folder) / "frame.exr"
            scene.render.filepath = str(path)
            assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
            img = bpy.data.images.load(str(path))
            px = np.empty(img.size[0] * img.size[1] * 4, np.float32)
            img.pixels.foreach_get(px)
            bpy.data.images.remove(img)
        out(f"{name} layered engine ({'layered' if mode else 'simple'})", digest(px))


def cloth(out, folder):
    """Four frames of the falling sheets corrected frame by frame. Blender's cloth solver is not
    bit-repeatable from run to run, so its simulation is baked to disk once (in ``folder``) and
    every later run corrects the same frames."""
    import bpy

    blend = Path(folder) / "sheets.blend"
    if blend.is_file():
        bpy.ops.wm.open_mainfile(filepath=str(blend))
    else:
        sheets = importlib.import_module("deformrt.sample_scenes.sheets")
        sheets.build(layers=4, per_sheet=2048, frames=40)
        Path(folder).mkdir(parents=True, exist_ok=True)
        bpy.ops.wm.save_as_mainfile(filepath=str(blend))
        for obj in bpy.context.scene.objects:
            for mod in obj.modifiers:
                if mod.type == "CLOTH":
                    mod.point_cache.use_disk_cache = True
        bpy.ops.ptcache.bake_all(bake=True)
        bpy.ops.wm.save_mainfile()
    scene = bpy.context.scene
    _, made = tagged(bpy, scene)
    scene.frame_set(1)
    scene.deformrt.resolve_on_frame_change = True
    for frame in range(1, 41):
        scene.frame_set(frame)
        if frame % 10 == 0:
            with_result = [a for o in made for a in evaluated(bpy, o)[:2]]
            out(f"sheets frame {frame}", digest(*with_result))
    scene.deformrt.resolve_on_frame_change = False


def jellyfish(out):
    jelly = importlib.import_module("deformrt.core.jellyfish")
    config = jelly.default_config()
    res = jelly.simulate_cycle(jelly.default_creature(config), config)
    out("jellyfish cycle", digest(np.array([res.path_m, res.bending_energy, res.energy_loss, res.fitness])))


def jellyfish_bake(out):
    """The baked bell and its parts at five frames (shape keys and keyframes from the default stroke)."""
    import bpy

    bpy.ops.wm.read_homefile(use_empty=True)
    assert bpy.ops.deformrt.add_jellyfish(size=0.5, segments=16, tentacles=4, veins=2) == {"FINISHED"}
    assert bpy.ops.deformrt.bake_jellyfish(frame_start=1, frame_end=30, cycle_frames=12) == {"FINISHED"}
    arrays = []
    for frame in (1, 5, 13, 22, 30):
        bpy.context.scene.frame_set(frame)
        for obj in bpy.context.scene.objects:
            if obj.type in ("MESH", "CURVE"):
                ev = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
                mesh = ev.to_mesh()
                co = np.empty(len(mesh.vertices) * 3, np.float32)
                mesh.vertices.foreach_get("co", co)
                ev.to_mesh_clear()
                arrays += [co, np.array(obj.matrix_world, np.float32)]
    out("jellyfish bake", digest(*arrays))


def main():
    import argparse

    ap = argparse.ArgumentParser()
    ap.add_argument("--cloth-folder", default="out/output_hashes", help="where the baked sheets are kept")
    args = ap.parse_args()
    load_package()
    lines = []

    def out(label, value):
        lines.append(f"{label}: {value}")
        print(lines[-1], flush=True)

    figures(out)
    cloth(out, Path(args.cloth_folder).resolve())
    jellyfish(out)
    jellyfish_bake(out)


if __name__ == "__main__":
    main()
