"""The one place mesh data crosses between Blender and numpy (foreach_get/foreach_set only)."""

from dataclasses import dataclass

import bpy
import numpy as np

from ...core.geometry.vectors import inverse3, matmul3


@dataclass
class MeshArrays:
    vertices: np.ndarray  # (n, 3) float64, world space unless read with world=False
    triangles: np.ndarray  # (m, 3) int64, loop triangles of the evaluated mesh
    triangle_polygon: np.ndarray  # (m,) polygon each triangle came from
    n_polygons: int = 0
    matrix_world: np.ndarray | None = None  # (4, 4) of the evaluated object
    triangle_material: np.ndarray | None = None  # (m,) material slot of each triangle, when asked for
    triangle_uv: np.ndarray | None = None  # (m, 3, 2) corner UVs of the render UV map, when asked for
    triangle_normals: np.ndarray | None = None  # (m, 3, 3) corner shading normals, when asked for


def _matrix(obj) -> np.ndarray:
    return np.array(obj.matrix_world, dtype=np.float64)


def read_mesh(obj, depsgraph=None, world=True, slots=False, shading=False, uvs=False) -> MeshArrays:
    """Evaluated geometry (modifiers, armature, cloth applied) of a mesh object; with ``slots``
    also each triangle's material slot; with ``shading``, unless every face is smooth with
    nothing sharp or custom (then None: its vertex normals say it all), its corners' shading
    normals, in world space when the vertices are; with ``uvs`` its corners' UVs on the UV map
    that renders (None without one)."""
    if depsgraph is None:
        depsgraph = bpy.context.evaluated_depsgraph_get()
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        # attributes and plain arrays: foreach_get over mesh.vertices or loop_triangles goes item by
        # item through RNA (Fig 4.12's meshes: 75 ms a read of positions, triangles and faces, 1 ms this way)
        n = len(mesh.vertices)
        co = np.empty(n * 3, dtype=np.float32)
        if n:  # an empty mesh has no position attribute
            mesh.attributes["position"].data.foreach_get("vector", co)
        mesh.calc_loop_triangles()
        m = len(mesh.loop_triangles)
        poly = np.empty(m, dtype=np.int32)
        mesh.loop_triangle_polygons.foreach_get("value", poly)
        n_polygons = len(mesh.polygons)
        loops = _triangle_loops(mesh, poly)
        corner_vert = mesh.attributes.get(".corner_vert")
        if corner_vert is not None and corner_vert.domain == "CORNER":
            per_corner = np.empty(len(mesh.loops), dtype=np.int32)
            corner_vert.data.foreach_get("value", per_corner)
            tris = per_corner[loops]
        else:
            tris = np.empty(m * 3, dtype=np.int32)
            mesh.loop_triangles.foreach_get("vertices", tris)
        slot = uv = corner = None
        if slots:
            # per face from its attribute (loop_triangles' own material_index is ten times slower)
            attr = mesh.attributes.get("material_index")
            if attr is None or attr.domain != "FACE" or not n_polygons:
                slot = np.zeros(m, dtype=np.int32)
            else:
                per_face = np.empty(n_polygons, dtype=np.int32)
                attr.data.foreach_get("value", per_face)
                slot = per_face[poly]
        layer = next((u for u in mesh.uv_layers if u.active_render), mesh.uv_layers.active) if uvs else None
        shaped = shading and m and not _plain_smooth(mesh)
        if layer is not None and m:
            per_loop = np.empty(len(mesh.loops) * 2, dtype=np.float32)
            layer.data.foreach_get("uv", per_loop)
            uv = per_loop.reshape(-1, 2)[loops].reshape(m, 3, 2).astype(np.float64)
        if shaped:
            per_loop = np.empty(len(mesh.loops) * 3, dtype=np.float32)
            mesh.corner_normals.foreach_get("vector", per_loop)
            corner = per_loop.reshape(-1, 3)[loops].astype(np.float64)
    finally:
        evaluated.to_mesh_clear()
    v = co.reshape(-1, 3).astype(np.float64)
    mw = np.array(evaluated.matrix_world, dtype=np.float64)
    if world:
        with np.errstate(invalid="ignore", over="ignore"):  # NaN or huge positions: the callers say which mesh
            v = matmul3(v, mw[:3, :3].T) + mw[:3, 3]
    if corner is not None:
        corner = world_normals(corner, mw) if world else corner
        corner = corner.reshape(-1, 3, 3)
    return MeshArrays(v, tris.reshape(-1, 3).astype(np.int64), poly.astype(np.int64), n_polygons, mw,
                      None if slot is None else slot.astype(np.int64), uv, corner)


def _triangle_loops(mesh, poly):
    """The corners of each loop triangle, flat, three a triangle. When every face is a triangle
    they are its own three corners, in order (a face's corners are contiguous, face after face),
    with no need to read them one by one; a bigger face's split is Blender's to choose."""
    if len(mesh.loops) == 3 * len(mesh.polygons) and len(poly) == len(mesh.polygons):
        return (3 * poly.astype(np.int64)[:, None] + np.arange(3)).ravel()
    loops = np.empty(len(poly) * 3, dtype=np.int32)
    mesh.loop_triangles.foreach_get("loops", loops)
    return loops


def _plain_smooth(mesh) -> bool:
    """Every face smooth, no sharp edge and no custom normals: shading by vertex normals."""
    if mesh.has_custom_normals:
        return False
    for name, domain in (("sharp_face", mesh.polygons), ("sharp_edge", mesh.edges)):
        attr = mesh.attributes.get(name)
        if attr is not None and len(domain):
            flags = np.empty(len(domain), dtype=bool)
            attr.data.foreach_get("value", flags)
            if flags.any():
                return False
    return True


def world_normals(normals, matrix_world):
    """(n, 3) object-space normals turned into world space (the inverse transpose of the matrix,
    so a non-uniform scale keeps them normal to the surface), made unit."""
    n = matmul3(normals, inverse3(np.asarray(matrix_world, float)[:3, :3]))
    length = np.linalg.norm(n, axis=1, keepdims=True)
    return np.divide(n, length, out=np.zeros_like(n), where=length > 0)


def fill_mesh(mesh, vertices, faces) -> None:
    """Replace a mesh datablock's geometry (vertices in the object's space) with triangles
    ((n, 3) array) or polygons of any size (a list of index sequences)."""
    v = np.ascontiguousarray(vertices, dtype=np.float32).reshape(-1)
    if isinstance(faces, np.ndarray) or not len(faces):
        f = np.ascontiguousarray(faces, dtype=np.int32).reshape(-1)
        sizes = np.full(len(f) // 3, 3, dtype=np.int32)
    else:
        sizes = np.fromiter((len(p) for p in faces), dtype=np.int32, count=len(faces))
        f = np.fromiter((i for p in faces for i in p), dtype=np.int32, count=int(sizes.sum()))
    mesh.clear_geometry()
    mesh.vertices.add(len(v) // 3)
    mesh.vertices.foreach_set("co", v)
    mesh.loops.add(len(f))
    mesh.loops.foreach_set("vertex_index", f)
    mesh.polygons.add(len(sizes))
    mesh.polygons.foreach_set("loop_start", (np.cumsum(sizes) - sizes).astype(np.int32))
    mesh.update()
    if mesh.validate(verbose=False):
        raise RuntimeError(f"mesh {mesh.name!r} had invalid geometry that Blender had to repair")


def new_mesh_object(name, vertices, faces, collection, smooth=True):
    mesh = bpy.data.meshes.new(name)
    fill_mesh(mesh, vertices, faces)
    if smooth:
        mesh.shade_smooth()
    obj = bpy.data.objects.new(name, mesh)
    collection.objects.link(obj)
    return obj


def write_vertex_groups(obj, names, weights, levels: int = 1024) -> None:
    """Vertex groups from an (n_vertices, n_groups) weight array.

    Blender has no bulk setter for group weights; weights are rounded to 1/levels so each
    group takes one ``VertexGroup.add`` call per distinct weight instead of one per vertex.
    """
    w = np.asarray(weights, dtype=np.float64)
    if w.shape != (len(obj.data.vertices), len(names)):
        raise ValueError(f"weights must be ({len(obj.data.vertices)}, {len(names)}), got {w.shape}")
    q = np.rint(np.clip(w, 0.0, 1.0) * levels).astype(np.int64)
    for g, name in enumerate(names):
        col = q[:, g]
        if not col.any():
            continue
        group = obj.vertex_groups.get(name) or obj.vertex_groups.new(name=name)
        order = np.argsort(col, kind="stable")
        values, starts = np.unique(col[order], return_index=True)
        for value, idx in zip(values, np.split(order, starts[1:]), strict=True):
            if value:
                group.add(idx.tolist(), float(value) / levels, "REPLACE")


def read_vertex_groups(obj, names):
    """(n_vertices, len(names)) weights of the named vertex groups on the evaluated mesh
    (after the modifier stack, as the geometry read by ``read_mesh``); 0 where a vertex is
    not in a group or the group does not exist.

    Blender has no bulk getter for group weights; a temporary Geometry Nodes modifier at the
    end of the stack copies each group into a float attribute, which ``foreach_get`` reads.
    """
    names = list(names)
    group = bpy.data.node_groups.new("DeformRT read groups", "GeometryNodeTree")
    mod = None
    try:
        group.interface.new_socket(name="Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
        group.interface.new_socket(name="Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
        nodes, links = group.nodes, group.links
        socket = nodes.new("NodeGroupInput").outputs["Geometry"]
        for i, name in enumerate(names):
            named = nodes.new("GeometryNodeInputNamedAttribute")
            named.data_type = "FLOAT"
            named.inputs["Name"].default_value = name
            store = nodes.new("GeometryNodeStoreNamedAttribute")
            store.data_type, store.domain = "FLOAT", "POINT"
            store.inputs["Name"].default_value = f"deformrt_read_{i}"
            links.new(socket, store.inputs["Geometry"])
            links.new(named.outputs["Attribute"], store.inputs["Value"])
            socket = store.outputs["Geometry"]
        links.new(socket, nodes.new("NodeGroupOutput").inputs["Geometry"])
        mod = obj.modifiers.new("DeformRT read groups", "NODES")
        mod.node_group = group
        evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
        mesh = evaluated.to_mesh()
        try:
            out = np.zeros((len(mesh.vertices), len(names)), dtype=np.float32)
            for i in range(len(names)):
                attr = mesh.attributes.get(f"deformrt_read_{i}")
                if attr is not None:
                    col = np.empty(len(mesh.vertices), dtype=np.float32)
                    attr.data.foreach_get("value", col)
                    out[:, i] = col
        finally:
            evaluated.to_mesh_clear()
    finally:
        if mod is not None:
            obj.modifiers.remove(mod)
        bpy.data.node_groups.remove(group)
    return out.astype(np.float64)


def write_point_ints(obj, name: str, values) -> None:
    """An integer per vertex as a mesh attribute (kept through modifiers such as Armature)."""
    mesh = obj.data
    attr = mesh.attributes.get(name)
    if attr is not None:
        mesh.attributes.remove(attr)
    attr = mesh.attributes.new(name, "INT", "POINT")
    attr.data.foreach_set("value", np.ascontiguousarray(values, dtype=np.int32))


def _read_point_attribute(obj, name, data_type, field, width, depsgraph):
    if depsgraph is None:
        depsgraph = bpy.context.evaluated_depsgraph_get()
    evaluated = obj.evaluated_get(depsgraph)
    mesh = evaluated.to_mesh()
    try:
        attr = mesh.attributes.get(name)
        if attr is None or attr.domain != "POINT" or attr.data_type != data_type:
            return None
        out = np.empty(len(mesh.vertices) * width, dtype=np.int32 if data_type == "INT" else np.float32)
        attr.data.foreach_get(field, out)
    finally:
        evaluated.to_mesh_clear()
    return out.reshape(-1, width) if width > 1 else out


def read_point_ints(obj, name: str, depsgraph=None):
    """The integer vertex attribute ``name`` of the evaluated mesh, or None if it has none."""
    out = _read_point_attribute(obj, name, "INT", "value", 1, depsgraph)
    return None if out is None else out.astype(np.int64)


def write_point_vectors(obj, name: str, values, color_name: str | None = None) -> None:
    """A vector per vertex as a mesh attribute; with ``color_name`` also as a colour
    attribute (v * 0.5 + 0.5) that the viewport can show (Solid shading, Attribute colour)."""
    mesh = obj.data
    v = np.ascontiguousarray(values, dtype=np.float32).reshape(-1, 3)
    for attr_name, kind in ((name, "FLOAT_VECTOR"), (color_name, "FLOAT_COLOR")):
        if attr_name is None:
            continue
        old = mesh.attributes.get(attr_name)
        if old is not None:
            mesh.attributes.remove(old)
        attr = mesh.attributes.new(attr_name, kind, "POINT")
        if kind == "FLOAT_VECTOR":
            attr.data.foreach_set("vector", v.ravel())
        else:
            rgba = np.ones((len(v), 4), dtype=np.float32)
            rgba[:, :3] = v * 0.5 + 0.5
            attr.data.foreach_set("color", rgba.ravel())
    if color_name is not None:
        mesh.color_attributes.active_color = mesh.color_attributes[color_name]


def read_point_vectors(obj, name: str, depsgraph=None):
    """The vector vertex attribute ``name`` of the evaluated mesh (object space), or None."""
    out = _read_point_attribute(obj, name, "FLOAT_VECTOR", "vector", 3, depsgraph)
    return None if out is None else out.astype(np.float64)
