"""The render's depsgraph read into what DeformRT Layered traces: every mesh that renders (tagged
ones layered, with their global normals and probe distances), its materials, UVs and shading
normals, and the ray scenes kept with Persistent Data."""

from dataclasses import dataclass, field

import numpy as np

from ...core.geometry.cache import Cache
from ...core.geometry.keys import digest
from ...core.geometry.vectors import inverse3, matmul3
from ...core.layering.probes import BodyParts, body_probes
from ...core.render.layered_trace import LayeredScene
from ...core.render.mesh_cleaning import finite_part
from ..io import mesh_io
from ..layers.scene_read import GLOBAL_NORMAL_ATTRIBUTE, body_parts, probe_distances
from .materials import materials


def meshes(depsgraph):
    """(object, its MeshArrays in world space, whether it stays outside the layering: an instance,
    the Materials of its slots) of every mesh the depsgraph shows: in a render, what renders (an
    object off for rendering is not there, one only hidden in the viewport is), the meshes
    collections and geometry nodes instance, and what curves, text and surfaces evaluate to."""
    known = {}
    for inst in depsgraph.object_instances:
        # a curve, text or surface object comes as its own entry and, what renders of it, as
        # an instance of the mesh it evaluates to: only meshes are read
        if inst.object.type != "MESH":
            continue
        obj = inst.object if inst.is_instance else inst.object.original
        mats = materials(obj, depsgraph, known)
        textured = any(m.texture is not None for m in mats)  # UVs only where a texture reads them
        if not inst.is_instance:
            yield obj, mesh_io.read_mesh(obj, depsgraph, slots=len(mats) > 1, shading=True, uvs=textured), False, mats
            continue
        # the instanced object's mesh, placed by the instance (read now: the iterator moves on)
        a = mesh_io.read_mesh(obj, depsgraph, world=False, slots=len(mats) > 1, shading=True, uvs=textured)
        m = np.array(inst.matrix_world, dtype=np.float64)
        normals = (None if a.triangle_normals is None
                   else mesh_io.world_normals(a.triangle_normals.reshape(-1, 3), m).reshape(-1, 3, 3))
        yield obj, mesh_io.MeshArrays(matmul3(a.vertices, m[:3, :3].T) + m[:3, 3], a.triangles, a.triangle_polygon,
                                      a.n_polygons, m, a.triangle_material, a.triangle_uv, normals), True, mats


# With the scene's Persistent Data on (Render Properties > Performance, as Cycles has it), the
# last frame's ray scenes (the BVHs, what is worn over each layer) are kept for the next render
# of the same meshes: look-development renders of a still pose build nothing again.
PERSISTENT = Cache(max_entries=1)


def _scene_key(objects, layers, normals, probe, offset):
    """A digest of all a LayeredScene is made from."""
    parts = [np.array([float(offset)]), np.array([-1 if lay is None else lay for lay in layers])]
    probes = probe if isinstance(probe, (list, tuple)) else [probe] * len(objects)
    for (v, f), n, p in zip(objects, normals, probes, strict=True):
        parts += [v, f, np.zeros(0) if n is None else n, np.full(1, np.nan) if p is None else np.atleast_1d(p)]
    return digest(*parts)


def layered_scene(objects, layers, normals, probe, offset, keep=False):
    """(LayeredScene, whether it was kept from the last render): with ``keep``, the last one if it
    was made from the same arrays, else a new one kept in its place; without, a new one, and
    nothing is held."""
    if not keep:
        PERSISTENT.clear()
        return LayeredScene(objects, layers, normals, probe_distance=probe, offset=offset), False
    key = _scene_key(objects, layers, normals, probe, offset)
    found = PERSISTENT.get(key)
    if found is not None:
        return found, True
    PERSISTENT.clear()  # the old scene's memory goes before the new one's comes
    made = LayeredScene(objects, layers, normals, probe_distance=probe, offset=offset)
    PERSISTENT.put(key, made)
    return made, False


@dataclass
class SceneRead:
    """What a render reads of its depsgraph, per object in the LayeredScene's order: the Materials
    of its slots, each triangle's slot (None with one slot), its triangles' corner UVs and shading
    normals (None where not needed), its pass index, whether it is a holdout and its Ray
    Visibility (per object: camera rays pass through it, it casts no shadow, it is not seen in
    reflections, nor through refraction); whether the LayeredScene was kept from the last render
    (``layered_scene``) and what was left out, said (``finite_part``)."""

    scene: LayeredScene = None
    kept: bool = False
    materials: list = field(default_factory=list)
    slots: list = field(default_factory=list)
    uvs: list = field(default_factory=list)
    shading: list = field(default_factory=list)
    pass_index: list = field(default_factory=list)
    holdout: list = field(default_factory=list)
    unseen: list = field(default_factory=list)
    shadowless: list = field(default_factory=list)
    unreflected: list = field(default_factory=list)
    unrefracted: list = field(default_factory=list)
    warnings: list = field(default_factory=list)

    def add(self, obj, a, mats) -> None:
        """One object's materials, surface arrays and switches."""
        self.materials.append(mats)
        self.slots.append(a.triangle_material if len(mats) > 1 else None)
        self.uvs.append(a.triangle_uv)
        self.shading.append(a.triangle_normals)
        self.pass_index.append(obj.pass_index)  # read now: an instance's object lasts while it is iterated
        self.unseen.append(not obj.visible_camera)
        self.shadowless.append(not obj.visible_shadow)
        self.unreflected.append(not obj.visible_glossy)
        self.unrefracted.append(not obj.visible_transmission)
        self.holdout.append(bool(obj.is_holdout))


def scene_arrays(depsgraph, layered=True) -> SceneRead:
    """The meshes the depsgraph shows, in world space, read into a SceneRead: a LayeredScene of
    them (tagged ones layered) and per object what shades it. Instances are drawn as they are,
    outside the layering. Without ``layered`` (plain ray tracing) the global normals, body parts
    and probe distances that only layering uses are not read."""
    read = SceneRead()
    objects, layers, normals = [], [], []
    settings = depsgraph.scene.deformrt
    parts = None
    for obj, a, outside, mats in meshes(depsgraph):
        a, lost = finite_part(a)
        if lost:
            read.warnings.append(f"{obj.name}: {lost} triangles at no finite position (NaN or infinite) left out")
        if not len(a.triangles):
            continue
        role = "NONE" if outside else obj.deformrt.role
        if role == "GARMENT" and not obj.visible_camera:
            role = "NONE"  # a garment the camera does not see covers nothing it sees
        objects.append((a.vertices, a.triangles))
        layers.append(None if role == "NONE" else (0 if role == "BODY" else obj.deformrt.layer))
        n = mesh_io.read_point_vectors(obj, GLOBAL_NORMAL_ATTRIBUTE, depsgraph) if layered and role != "NONE" else None
        # stored in object space; normals turn with the inverse transpose
        normals.append(None if n is None or len(n) != len(a.vertices) else matmul3(n, inverse3(a.matrix_world[:3, :3])))
        read.add(obj, a, mats)
        if layered and role == "BODY":
            # no vertex groups: reading them adds a modifier, and a render must not write to the scene
            parts, _ = body_parts(obj, settings.scheme, a.vertices, groups=False, depsgraph=depsgraph)
            if parts is not None and len(parts) != len(a.vertices):
                parts = None
    scheme = settings.scheme if parts is not None else None  # body_parts finds none without a scheme
    probe = 0.0
    if layered:
        top = max((lay for lay in layers if lay is not None), default=0)
        probe = body_probes(objects, layers, probe_distances(settings, parts is not None),
                            None if parts is None else BodyParts(parts, scheme),
                            traced=[lay is not None and lay < top for lay in layers], gap=settings.offset)
    read.scene, read.kept = layered_scene(objects, layers, normals, probe, settings.offset,
                                          keep=depsgraph.scene.render.use_persistent_data)
    return read
