"""The built extension in a bpy session: registration, tagging operators, mesh IO and the CLI."""

import importlib
import subprocess
import sys
import threading

import bpy
import numpy as np
import pytest

MODULE = "bl_ext.deformrt_test.deformrt"


def add_mesh(name, location=(0, 0, 0)):
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([(0, 0, 0), (1, 0, 0), (0, 1, 0)], [], [(0, 1, 2)])
    obj = bpy.data.objects.new(name, mesh)
    obj.location = location
    bpy.context.scene.collection.objects.link(obj)
    return obj


def select(*objs, active=None):
    bpy.context.view_layer.update()  # newly linked objects join the view layer on update
    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    for o in objs:
        o.select_set(True)
    bpy.context.view_layer.objects.active = active if active is not None else (objs[0] if objs else None)


def test_installed_from_zip_not_from_checkout(extension):
    assert extension.__name__ == MODULE
    assert "/repo/deformrt/" in extension.__file__.replace("\\", "/")
    assert extension.core.rays.HAVE_EMBREE


def test_register_unregister_register_leaves_nothing_behind(clean_scene, extension):
    cache = importlib.import_module(MODULE + ".core.rays.scene_cache")
    cache.kept_scene(b"a garment as it came", np.eye(3), np.array([[0, 1, 2]]))  # what a resolve keeps
    assert cache.kept_bytes() > 0
    parallel = importlib.import_module(MODULE + ".core.geometry.parallel")
    parallel.map_chunks(lambda sl: sl.stop - sl.start, 1000, 1, threads=2)  # the shared pool's threads start
    assert any(t.name.startswith("deformrt") for t in threading.enumerate())
    assert bpy.ops.preferences.addon_disable(module=MODULE) == {"FINISHED"}
    try:
        assert cache.kept_bytes() == 0  # disabling the add-on gives the kept ray scenes back
        assert not [t.name for t in threading.enumerate() if t.name.startswith("deformrt")]  # and its threads
        assert not hasattr(bpy.types.Object, "deformrt")
        assert not hasattr(bpy.types.Scene, "deformrt")
        for name in ("DEFORMRT_PT_layers", "DEFORMRT_OT_tag_body", "DEFORMRT_OT_move_layer"):
            assert not hasattr(bpy.types, name), name
        assert "tag_body" not in dir(bpy.ops.deformrt)
    finally:
        assert bpy.ops.preferences.addon_enable(module=MODULE) == {"FINISHED"}
    assert hasattr(bpy.types.Object, "deformrt")
    assert hasattr(bpy.types, "DEFORMRT_PT_layers")
    assert bpy.context.scene.deformrt.resolve_on_frame_change is False


def test_tag_body_replaces_the_previous_body(clean_scene):
    first, second = add_mesh("First"), add_mesh("Second")
    select(first)
    assert bpy.ops.deformrt.tag_body() == {"FINISHED"}
    select(second)
    assert bpy.ops.deformrt.tag_body() == {"FINISHED"}
    assert (first.deformrt.role, second.deformrt.role, second.deformrt.layer) == ("NONE", "BODY", 0)


def test_tag_body_needs_an_active_mesh(clean_scene):
    empty = bpy.data.objects.new("Empty", None)
    clean_scene.collection.objects.link(empty)
    select(empty)
    assert not bpy.ops.deformrt.tag_body.poll()
    with pytest.raises(RuntimeError, match="Select a mesh object"):
        bpy.ops.deformrt.tag_body()


def test_tag_garments_stack_above_existing_layers(clean_scene):
    a, b, c = add_mesh("A"), add_mesh("B"), add_mesh("C")
    select(a)
    bpy.ops.deformrt.tag_garments()
    select(c, b)
    bpy.ops.deformrt.tag_garments()
    assert [o.deformrt.layer for o in (a, b, c)] == [1, 2, 3]
    assert all(o.deformrt.role == "GARMENT" for o in (a, b, c))
    # tagging again keeps existing layers
    select(a, b, c)
    bpy.ops.deformrt.tag_garments()
    assert [o.deformrt.layer for o in (a, b, c)] == [1, 2, 3]


def test_move_layer_swaps_neighbours_and_stops_at_the_body(clean_scene):
    a, b = add_mesh("A"), add_mesh("B")
    select(a, b)
    bpy.ops.deformrt.tag_garments()
    assert bpy.ops.deformrt.move_layer(object_name="A", direction="UP") == {"FINISHED"}
    assert (a.deformrt.layer, b.deformrt.layer) == (2, 1)
    assert bpy.ops.deformrt.move_layer(object_name="B", direction="DOWN") == {"CANCELLED"}
    assert (a.deformrt.layer, b.deformrt.layer) == (2, 1)
    with pytest.raises(RuntimeError, match="Nothing to move"):
        bpy.ops.deformrt.move_layer(object_name="Missing")


def test_clear_role(clean_scene):
    a = add_mesh("A")
    select(a)
    bpy.ops.deformrt.tag_garments()
    assert bpy.ops.deformrt.clear_role() == {"FINISHED"}
    assert (a.deformrt.role, a.deformrt.layer) == ("NONE", 0)
    assert not bpy.ops.deformrt.clear_role.poll()


def test_mesh_io_round_trip_in_world_space(extension, clean_scene):
    mesh_io = importlib.import_module(MODULE + ".addon.io.mesh_io")
    rng = np.random.default_rng(0)
    v = rng.normal(size=(50, 3))
    f = rng.integers(0, 50, size=(40, 3))
    f = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])]
    f = np.unique(np.sort(f, axis=1), axis=0)
    obj = mesh_io.new_mesh_object("Soup", v, f, clean_scene.collection, smooth=False)
    obj.location = (1.0, -2.0, 3.0)
    obj.rotation_euler = (0.3, 0.2, 0.1)
    obj.scale = (2.0, 1.0, 0.5)
    got = mesh_io.read_mesh(obj, bpy.context.evaluated_depsgraph_get())
    m = np.array(obj.matrix_world)
    np.testing.assert_allclose(got.vertices, v @ m[:3, :3].T + m[:3, 3], atol=1e-5)
    np.testing.assert_array_equal(np.sort(got.triangles, axis=1), np.sort(f, axis=1))
    local = mesh_io.read_mesh(obj, world=False)
    np.testing.assert_allclose(local.vertices, v, atol=1e-6)


@pytest.mark.parametrize("shape", ["triangles", "mixed"])
def test_mesh_io_reads_what_blender_says_triangle_by_triangle(extension, clean_scene, shape):
    """Positions, loop triangles, their faces, UVs and corner normals read through attributes
    and whole arrays are what Blender's own per-item properties give: on a mesh of triangles
    only (their corners taken face by face without reading them) and on one of quads, an ngon
    and triangles, flat-shaded in part, where Blender chooses the split."""
    mesh_io = importlib.import_module(MODULE + ".addon.io.mesh_io")
    if shape == "triangles":
        bpy.ops.mesh.primitive_uv_sphere_add(segments=24, ring_count=12)
        obj = bpy.context.active_object
        obj.modifiers.new("Tri", "TRIANGULATE")
    else:
        # a bent 5 x 5 grid of quads, a hexagon and a triangle
        x, y = np.meshgrid(np.arange(6.0), np.arange(6.0))
        grid = np.column_stack([x.ravel(), y.ravel(), 0.1 * x.ravel() ** 2])
        quads = [(6 * j + i, 6 * j + i + 1, 6 * j + i + 7, 6 * j + i + 6) for j in range(5) for i in range(5)]
        angle = np.arange(6) * np.pi / 3
        hexagon = np.column_stack([8 + np.cos(angle), np.sin(angle), 0.3 * np.sin(2 * angle)])
        verts = np.vstack([grid, hexagon, [[10.0, 0, 0], [11, 0, 0], [10, 1, 0]]])
        faces = [*quads, tuple(range(36, 42)), (42, 43, 44)]
        data = bpy.data.meshes.new("Mixed")
        data.from_pydata(verts.tolist(), [], faces)
        data.uv_layers.new()
        obj = bpy.data.objects.new("Mixed", data)
        clean_scene.collection.objects.link(obj)
        data.polygons[5].use_smooth = True  # the rest flat: corner normals differ from vertex normals
    obj.modifiers.new("Twist", "SIMPLE_DEFORM").deform_axis = "Z"
    obj.location = (0.5, -1.0, 2.0)
    obj.rotation_euler = (0.3, 0.2, 0.1)
    got = mesh_io.read_mesh(obj, slots=True, shading=True, uvs=True)
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    mesh = evaluated.to_mesh()
    mesh.calc_loop_triangles()
    sizes = {len(p.vertices) for p in mesh.polygons}
    assert sizes == ({3} if shape == "triangles" else {3, 4, 6})
    m = np.array(obj.matrix_world)
    co = np.array([v.co[:] for v in mesh.vertices])
    np.testing.assert_allclose(got.vertices, co @ m[:3, :3].T + m[:3, 3], atol=1e-6)
    np.testing.assert_array_equal(got.triangles, [t.vertices[:] for t in mesh.loop_triangles])
    np.testing.assert_array_equal(got.triangle_polygon, [t.polygon_index for t in mesh.loop_triangles])
    uv = mesh.uv_layers.active.data
    np.testing.assert_allclose(got.triangle_uv, [[uv[k].uv[:] for k in t.loops] for t in mesh.loop_triangles],
                               atol=1e-7)
    normals = [[mesh.corner_normals[k].vector[:] for k in t.loops] for t in mesh.loop_triangles]
    np.testing.assert_allclose(got.triangle_normals, mesh_io.world_normals(
        np.reshape(normals, (-1, 3)), m).reshape(-1, 3, 3), atol=1e-6)
    evaluated.to_mesh_clear()


def test_mesh_io_reads_evaluated_modifiers(extension, clean_scene):
    bpy.ops.mesh.primitive_cube_add()
    cube = bpy.context.active_object
    cube.modifiers.new("Sub", "SUBSURF").levels = 1
    got = importlib.import_module(MODULE + ".addon.io.mesh_io").read_mesh(cube)
    assert len(got.triangles) == 6 * 4 * 2  # subdivided once: 24 quads, 48 triangles
    assert len(cube.data.polygons) == 6  # the original is untouched


def test_cli_info_inside_blender(extension, capsys):
    assert importlib.import_module(extension.__name__ + ".sample_scenes.cli.commands").main(["info"]) == 0
    out = capsys.readouterr().out
    assert "Embree (embreex)" in out and "4.5" in out
    assert importlib.import_module(extension.__name__ + ".sample_scenes.cli.commands").main(["no-such-command"]) == 2


def test_cli_from_plain_python_runs_the_installed_extension(extension, tmp_path):
    ext_dir = extension.__file__.rsplit("/", 1)[0]
    run = subprocess.run([sys.executable, ext_dir, "demo", "--scene", "tubes", "--out", str(tmp_path), "--width", "64",
                          "--height", "64", "--samples", "2"], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    assert (tmp_path / "before.png").stat().st_size > 1000
    table = (tmp_path / "metrics.md").read_text()
    assert "| Body | body | 0 |" in table
    # what an artist wants first: poke-through before and after, in plain words
    headline = [line for line in table.splitlines() if line.strip()][1]
    assert headline.startswith("**Poke-through:") and "before" in headline and "after" in headline
    for internal in ("deformrt_part", "correspondence", "push-behind", "_s |", "counted in the rows"):
        assert internal not in table, internal


def test_garments_tagged_together_are_ordered_by_kind(clean_scene):
    # MakeHuman's z_depth order: underwear < shirt, trousers < sweater < jacket < coat
    names = ["Winter Coat", "T-Shirt", "Boxers", "Denim Jacket", "Cardigan", "Overshirt"]
    objs = [add_mesh(n) for n in names]
    select(*objs)
    bpy.ops.deformrt.tag_garments()
    order = sorted(objs, key=lambda o: o.deformrt.layer)
    assert [o.name for o in order] == ["Boxers", "T-Shirt", "Overshirt", "Cardigan", "Denim Jacket", "Winter Coat"]
    # the user moves the coat in; Order by Kind puts it back out
    coat = objs[0]
    for _ in range(5):
        bpy.ops.deformrt.move_layer(object_name=coat.name, direction="DOWN")
    assert coat.deformrt.layer == 1
    bpy.ops.deformrt.order_by_kind()
    assert [o.deformrt.layer for o in order] == [1, 2, 3, 4, 5, 6]


def _mpfb(obj, kind, z_depth=None, parent=None):
    """An object as MPFB2 leaves it: its type in GeneralObjectProperties (MPFB_GEN_), the clothes'
    z_depth in MakeClothesObjectProperties (MC_), parented to the character's rig."""
    obj["MPFB_GEN_object_type"] = kind
    if z_depth is not None:
        obj["MC_z_depth"] = z_depth
    obj.parent = parent
    return obj


def _character(name, z_depths=True):
    rig = bpy.data.objects.new(f"{name}.rig", bpy.data.armatures.new(f"{name}.rig"))
    bpy.context.scene.collection.objects.link(rig)
    body = _mpfb(add_mesh(f"{name}.body"), "Basemesh", parent=rig)
    _mpfb(add_mesh(f"{name}.eyes"), "Eyes", parent=rig)
    # MakeHuman's z_depths: a name that says nothing, and one that says the opposite of its depth
    clothes = [_mpfb(add_mesh(f"{name}.{n}"), "Clothes", d if z_depths else None, parent=rig)
               for n, d in (("jacket_lining", 30), ("Outfit 2", 60), ("t_shirt", 45))]
    return rig, body, clothes


def test_one_click_tags_a_makehuman_character_in_its_z_depth_order(clean_scene):
    rig, body, (lining, outfit, shirt) = _character("Anna")
    stray = add_mesh("stray garment")
    stray.deformrt.role = "GARMENT"
    assert bpy.ops.deformrt.tag_makehuman() == {"FINISHED"}
    assert body.deformrt.role == "BODY"
    assert [o.deformrt.layer for o in (lining, shirt, outfit)] == [1, 2, 3]  # by z_depth, not by name
    assert all(o.deformrt.role == "GARMENT" for o in (lining, shirt, outfit))
    assert bpy.data.objects["Anna.eyes"].deformrt.role == "NONE" and stray.deformrt.role == "NONE"
    # a proxy that renders is the body the clothes lie on
    proxy = _mpfb(add_mesh("Anna.proxy"), "Proxymeshes", parent=rig)
    assert bpy.ops.deformrt.tag_makehuman() == {"FINISHED"}
    assert proxy.deformrt.role == "BODY" and body.deformrt.role == "NONE"
    # its base mesh deleted, the proxy alone is the character (it used to be "no character")
    bpy.data.objects.remove(body)
    proxy.deformrt.role = "NONE"
    assert bpy.ops.deformrt.tag_makehuman() == {"FINISHED"}
    assert proxy.deformrt.role == "BODY" and [o.deformrt.layer for o in (lining, shirt, outfit)] == [1, 2, 3]


def test_without_z_depths_the_clothes_go_by_kind_and_two_characters_need_a_choice(clean_scene, capfd):
    _, _, (lining, outfit, shirt) = _character("Ben", z_depths=False)
    assert bpy.ops.deformrt.tag_makehuman() == {"FINISHED"}
    assert [o.name for o in sorted((lining, outfit, shirt), key=lambda o: o.deformrt.layer)] == \
        ["Ben.Outfit 2", "Ben.t_shirt", "Ben.jacket_lining"]  # unknown and shirt (1) < jacket (3)
    _, cleo_body, cleo_clothes = _character("Cleo")
    select()
    with pytest.raises(RuntimeError, match="More than one MakeHuman character"):
        bpy.ops.deformrt.tag_makehuman()
    select(cleo_clothes[1])
    capfd.readouterr()
    assert bpy.ops.deformrt.tag_makehuman() == {"FINISHED"}
    assert cleo_body.deformrt.role == "BODY" and lining.deformrt.role == "NONE"
    said = capfd.readouterr()
    # Ben's tags went: the report says whose
    assert "untagged (one character is layered at a time): Ben.body" in said.out + said.err


def test_tooltips_are_one_plain_sentence(extension):
    """Every operator's and setting's tooltip: one line, no thesis symbols or references, and
    every setting has one."""
    jargon = ("thesis", "seed", "(d)", "(l_s)", "eq.", "Fig.")
    ops = [getattr(bpy.ops.deformrt, name).get_rna_type() for name in dir(bpy.ops.deformrt)]
    assert len(ops) > 15
    for rna in ops:
        text = rna.description
        assert text and "\n" not in text and "  " not in text and len(text) <= 120, (rna.identifier, text)
        assert not any(j in text for j in jargon), (rna.identifier, text)
    groups = [bpy.types.Object.bl_rna.properties["deformrt"].fixed_type,
              bpy.types.Scene.bl_rna.properties["deformrt"].fixed_type]
    for group in groups:
        for prop in group.properties:
            if prop.identifier in {"rna_type", "name"} or prop.is_hidden:
                continue
            text = prop.description
            assert text and "\n" not in text and not any(j in text for j in jargon), (prop.identifier, text)


_INSTALL = """
import bpy, sys
assert bpy.ops.extensions.package_install_files(repo="user_default", filepath=sys.argv[1],
                                                 enable_on_install=True) == {"FINISHED"}
"""
# what the README tells a pipeline to put at the top of its script: an extension installed once
# is enabled in each new Blender process (enabling is a preference, not saved by a script)
_PIPELINE = """
import bpy
bpy.ops.preferences.addon_enable(module="bl_ext.user_default.deformrt")
import importlib
importlib.import_module("bl_ext.user_default.deformrt.sample_scenes.tubes").build(seed=0, resolution=24)
print("RESOLVE", bpy.ops.deformrt.resolve_layers())
"""


def test_installed_once_a_headless_pipeline_enables_it_in_each_new_process(extension_zip, tmp_path):
    """The README's recipe for `blender -b` and bpy pipelines, run as two processes sharing one
    Blender user folder: the zip installed in the first; the second enables it by its module name
    and resolves."""
    import os

    env = {**os.environ, "BLENDER_USER_RESOURCES": str(tmp_path / "user")}
    install, pipeline = tmp_path / "install.py", tmp_path / "pipeline.py"
    install.write_text(_INSTALL)
    pipeline.write_text(_PIPELINE)
    first = subprocess.run([sys.executable, str(install), str(extension_zip)], env=env, capture_output=True,
                           text=True, timeout=300)
    assert first.returncode == 0, first.stdout + first.stderr
    second = subprocess.run([sys.executable, str(pipeline)], env=env, capture_output=True, text=True, timeout=300)
    assert second.returncode == 0 and "RESOLVE {'FINISHED'}" in second.stdout, second.stdout + second.stderr


def test_this_platforms_build_bundles_what_blenders_own_split_gives_that_platform(extension_zip):
    """`.ci/build.py --this-platform` picks each platform's wheels by their tags; the reference is
    what Blender's extension tool itself put in each platform's zip of the full build."""
    import importlib.util
    import tomllib
    import zipfile

    root = extension_zip.parent.parent
    spec = importlib.util.spec_from_file_location("ci_build", root / ".ci" / "build.py")
    build = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(build)
    text = (root / "blender_manifest.toml").read_text()
    manifest = tomllib.loads(text)
    for plat in manifest["platforms"]:
        picked = [w for w in manifest["wheels"] if build.serves(w.rsplit("/", 1)[-1], plat)]
        made = extension_zip.parent / f"{manifest['id']}-{manifest['version']}-{plat.replace('-', '_')}.zip"
        with zipfile.ZipFile(made) as z:
            bundled = {n.rsplit("/", 1)[-1] for n in z.namelist() if n.endswith(".whl")}
        assert {w.rsplit("/", 1)[-1] for w in picked} == bundled, plat
        # and the one-platform manifest it builds from names just those
        cut = tomllib.loads(build.one_platform_manifest(text, plat, picked))
        assert cut["platforms"] == [plat] and cut["wheels"] == picked
