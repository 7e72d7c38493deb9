"""Resolve the role-tagged objects of a scene: read once, call core, write once.

Used by the operators, the frame-change handler and the command line, so all of them
check the scene the same way and leave the same non-destructive result.
"""

import time
from contextlib import contextmanager
from dataclasses import dataclass, field

import bpy
import numpy as np
import trimesh

from ...core.geometry.cache import Cache
from ...core.geometry.vectors import cross, norms, rows, size_of
from ...core.layering import metrics
from ...core.layering.covered_skin import covered_faces
from ...core.layering.resolve import resolve_layers
from ...core.layering.segmentation import get_scheme, part_of_group, segments_from_groups
from ..io import mesh_io, scene_units
from . import result_stack, results, scene_roles, staleness
from .report import LayersReport

PART_GROUP_PREFIX = "DRT_"
GLOBAL_NORMAL_ATTRIBUTE = "deformrt_global_normal"
GLOBAL_NORMAL_COLOR = "deformrt_global_normal_color"
# Garment-to-body correspondence of an animation's last resolved frame, carried to the next
# instead of searching again (the thesis' posed pipeline; core re-searches where it drifted),
# and that frame's result (core's ``previous``: what it hid is held a few frames).
_correspondence_cache = Cache(max_entries=1)
_last_frame = Cache(max_entries=1)
_parts_cache = Cache(max_entries=1)


class LayeringInputError(ValueError):
    """The scene cannot be resolved as it is; the message says what to change."""


@dataclass
class ResolveSummary:
    body: str
    garments: list
    parts_source: str
    stats: dict
    max_move: list  # per garment, scene units
    faces_hidden: list  # per garment, polygons
    seconds: dict = field(default_factory=dict)
    inward: list = field(default_factory=list)  # garments whose faces mostly face the body
    probe_by_part: dict = field(default_factory=dict)  # l_s the resolve used, scene units
    alone: list = field(default_factory=list)  # garments near no other, left as they were
    skin_hidden: int = 0  # body faces under cloth left out (Hide Covered Skin)
    moved_after: list = field(default_factory=list)  # "garment's modifier": moves what was corrected
    length: object = lambda v: f"{v * 1000:.1f} mm"  # a length in the scene's units (scene_units)

    def message(self) -> str:
        moved = max(self.max_move, default=0.0)
        alone = f"; near no other garment, left as fitted: {', '.join(self.alone)}" if self.alone else ""
        skin = f", {self.skin_hidden} covered skin faces hidden" if self.skin_hidden else ""
        notes = (f"; {self.body}'s faces point inward (flipped, or a negative scale): resolved the right way "
                 "out" if self.stats.get("body_inside_out") else "")
        far = self.stats.get("vertices_far_from_body", 0)
        if far:  # the method's known limit: cloth beyond the probe's reach from its body part is not probed
            notes += (f"; {far} garment points farther from the body than the Reach still showed through and were "
                      "hidden (raise Reach, or move the garments onto the body)")
        if self.moved_after:  # what renders is moved again after the correction
            notes += (f"; {', '.join(self.moved_after)} run after DeformRT and move what it corrected (move them "
                      "above DeformRT and resolve again)")
        return (f"Resolved {len(self.garments)} garments on {self.body} in {self.seconds['total_s']:.2f} s: "
                f"max move {self.length(moved)}, {sum(self.faces_hidden)} faces hidden{skin} "
                f"(body parts from {self.parts_source}){alone}{notes}")

    def report(self) -> LayersReport:
        return LayersReport(
            kind="resolve", message=self.message(), seconds=self.seconds, garments=self.garments,
            max_move=self.max_move, faces_hidden=self.faces_hidden, parts=self.parts_source,
            skirts=[self.garments[i] for i in self.stats["skirts"]], far_from_body=self.stats["vertices_far_from_body"],
            inward=self.inward, probe_by_part=self.probe_by_part,
            stages_s={k: v for k, v in self.stats.items() if k.endswith("_s")})


def layered_objects(scene):
    """(body, garments inner to outer) after checking the scene can be resolved."""
    odd = [o for o in scene_roles.tagged(scene, "BODY") + scene_roles.tagged(scene, "GARMENT") if o.type != "MESH"]
    if odd:
        raise LayeringInputError(f"{odd[0].name} is a {odd[0].type.lower()}, not a mesh: clear its role")
    bodies = scene_roles.bodies(scene)
    if not bodies:
        raise LayeringInputError("No body: select the figure and press Tag as Body")
    if len(bodies) > 1:
        raise LayeringInputError(f"More than one body ({', '.join(o.name for o in bodies)}): keep one")
    garments = scene_roles.garments(scene)
    if not garments:
        raise LayeringInputError("No garments: select them and press Tag as Garments")
    view_layer = bpy.context.view_layer
    for obj in [bodies[0], *garments]:
        hidden = obj.hide_viewport or (view_layer is not None and obj.name in view_layer.objects
                                       and obj.hide_get(view_layer=view_layer))
        if hidden or (view_layer is not None and obj.name not in view_layer.objects):
            raise LayeringInputError(f"{obj.name} is hidden or not in the view layer: show it or clear its role")
    for obj in [bodies[0], *garments]:
        linked = obj.library or obj.data.library
        if linked is not None:
            # the result is a modifier and data on the object: linked data cannot take them
            raise LayeringInputError(f"{obj.name} is linked from {linked.filepath}: make a library override of it "
                                     "(Object > Library Override > Make) or make it local, then resolve")
    layers = [o.deformrt.layer for o in garments]
    for a, b in zip(garments, garments[1:], strict=False):
        if a.deformrt.layer == b.deformrt.layer:
            raise LayeringInputError(f"{a.name} and {b.name} are both on layer {a.deformrt.layer}: "
                                     "move one with the arrows in the Layers panel")
    if min(layers) < 1:
        raise LayeringInputError(f"{garments[0].name} is on layer {min(layers)}: garments start at layer 1")
    return bodies[0], garments


def part_groups(obj, scheme) -> list:
    """The object's DRT_<part> vertex group names of ``scheme``, in the scheme's order."""
    names = [PART_GROUP_PREFIX + p for p in scheme.parts]
    return [n for n in names if n in obj.vertex_groups]


def body_parts(body, scheme_name, vertices, painted_groups=True, groups=True, depsgraph=None):
    """Part id per evaluated body vertex, and where it came from; (None, reason) without.

    In order: DRT_<part> vertex groups (auto-segmented or painted), the stored part
    attribute of the sample figures, a rig's deform groups named after the limbs. Reading
    groups adds a modifier for a moment; ``groups`` False (inside a render) reads only the
    stored attribute, from ``depsgraph`` when given."""
    if scheme_name == "NONE":
        return None, "none: the whole body as one"
    scheme = get_scheme(scheme_name)
    painted = ([n for n in part_groups(body, scheme) if n != PART_GROUP_PREFIX + "skirt"]
               if painted_groups and groups else [])
    if painted:
        w = mesh_io.read_vertex_groups(body, painted)
        names = [n[len(PART_GROUP_PREFIX):] for n in painted]
        return segments_from_groups(w, names, scheme, vertices), "the painted DRT_ part groups"
    stored = mesh_io.read_point_ints(body, scene_roles.PART_ATTRIBUTE[scheme.name], depsgraph)
    if stored is not None:
        return np.clip(stored, 0, scheme.skirt - 1), "the parts stored with the figure"
    names = [g.name for g in body.vertex_groups if not g.name.startswith(PART_GROUP_PREFIX)] if groups else []
    if names and len({part_of_group(n, scheme) for n in names}) > 1:
        w = mesh_io.read_vertex_groups(body, names)
        return segments_from_groups(w, names, scheme, vertices), "the rig's vertex groups"
    return None, "its separate pieces (no part groups on the body)"


def garment_parts(garment, scheme_name):
    """Segment per evaluated garment vertex from its DRT_<part> groups, or None (nearest body part)."""
    if scheme_name == "NONE":
        return None
    scheme = get_scheme(scheme_name)
    painted = part_groups(garment, scheme)
    if not painted:
        return None
    w = mesh_io.read_vertex_groups(garment, painted)
    ids = np.array([scheme.parts.index(n[len(PART_GROUP_PREFIX):]) for n in painted])
    return ids[np.argmax(w, axis=1)]


@contextmanager
def results_bypassed(garments):
    """Garments evaluate as their own stack makes them (any earlier result switched off)."""
    with staleness.paused():
        shown = [results.set_enabled(g, False) for g in garments]
        try:
            yield
        finally:
            for g, was in zip(garments, shown, strict=True):
                if was:
                    results.set_enabled(g, True)


@contextmanager
def fitted_cages(garments):
    """Garments evaluate as fitted, up to where their result sits (``result_stack``): the
    vertices a result is made for, the same in the viewport and the render."""
    with results_bypassed(garments), result_stack.cages_shown(garments):
        yield


def _trimesh(a):
    return trimesh.Trimesh(a.vertices, a.triangles, process=False, validate=False)


def _correspondence_only(arrays, **params):
    """resolve_layers with every moving stage off: segments, skirts and global normals."""
    return resolve_layers(_trimesh(arrays[0]), [_trimesh(a) for a in arrays[1:]], boundary_pass=False,
                          push_behind=False, remove_hidden=False, **params)


def _check_own_vertices(objs, arrays, what):
    for obj, a in zip(objs, arrays, strict=True):
        if len(obj.data.vertices) != len(a.vertices):
            raise LayeringInputError(f"{obj.name}'s modifiers change its vertex count ({len(obj.data.vertices)} -> "
                                     f"{len(a.vertices)}): {what}")


def read_meshes(objs, depsgraph):
    """Evaluated meshes of ``objs`` (world space), each checked to sit at finite positions: a cloth
    solver that blew up or a driver dividing by zero is named here, before anything is changed,
    not by its index in a list deep in core."""
    arrays = [mesh_io.read_mesh(o, depsgraph) for o in objs]
    for obj, a in zip(objs, arrays, strict=True):
        lost = int((~np.isfinite(a.vertices).all(axis=1)).sum())
        if lost:
            raise LayeringInputError(f"{obj.name} has {lost} vertices at no finite position (NaN or infinite) "
                                     "after its modifiers: fix or re-bake it; nothing was changed")
    return arrays


def _parts_key(body, scheme_name) -> tuple:
    """What the body's parts are read from: its groups (names), vertex count and the scheme."""
    return body.name, len(body.data.vertices), scheme_name, tuple(g.name for g in body.vertex_groups)


def read_scene(scene, scheme_name, playing=False):
    """Evaluated body and garments (world space) without any earlier result applied. ``playing``
    (frame after frame): the body's parts, read from its groups on the first frame, are kept
    while its groups are the same (reading 160 rig groups costs 0.4 s a frame)."""
    body, garments = layered_objects(scene)
    for obj in [body, *garments]:  # every result must have its place before any is written
        problem = result_stack.placement_problem(obj)
        if problem:
            raise LayeringInputError(problem)
    for obj in [body, *garments]:  # read as fitted, not through what another field points at
        results.disconnect_foreign(obj)
        mod = results.result_modifier(obj)
        if mod is not None:  # read where the result goes: a modifier added after it since runs above it
            result_stack.place(obj, mod)
    # the body too, up to where its own result (covered skin) goes: a subdivided body is smoothed
    # inside its cage, so cloth clear of the cage is clear of what renders
    with fitted_cages([body, *garments]):
        depsgraph = bpy.context.evaluated_depsgraph_get()
        arrays = read_meshes([body, *garments], depsgraph)
        key = (*_parts_key(body, scheme_name), len(arrays[0].vertices))
        kept = _parts_cache.get(key) if playing else None
        if kept is None:
            kept = body_parts(body, scheme_name, arrays[0].vertices)
            if playing:
                _parts_cache.put(key, kept)
        parts, source = kept
        g_parts = [garment_parts(g, scheme_name) for g in garments]
        g_normals = []
        for g, a in zip(garments, arrays[1:], strict=True):
            n = mesh_io.read_point_vectors(g, GLOBAL_NORMAL_ATTRIBUTE, depsgraph)
            # stored in object space; normals turn with the inverse transpose
            g_normals.append(None if n is None or len(n) != len(a.vertices)
                             else n @ np.linalg.inv(a.matrix_world[:3, :3]))
    return body, garments, arrays, parts, source, g_parts, g_normals


def probe_distances(settings, has_parts):
    """The probe distance to pass to core: None (each part's radius), one distance, or one per
    part with NaN where the part keeps its default (the panel's per-part overrides)."""
    base = settings.probe_distance if settings.probe_distance > 0 else np.nan
    if settings.scheme == "NONE" or not has_parts or not len(settings.part_probes):
        return None if np.isnan(base) else float(base)
    parts = get_scheme(settings.scheme).parts
    out = np.full(len(parts), base)
    for item in settings.part_probes:
        if item.part in parts:
            out[parts.index(item.part)] = item.distance
    return out


def _topology_key(objs, arrays):
    return tuple((o.name, len(a.vertices), len(a.triangles)) for o, a in zip(objs, arrays, strict=True))


def forget_correspondence():
    _correspondence_cache.clear()
    _last_frame.clear()
    _parts_cache.clear()


def kept_correspondence() -> dict:
    return dict(_correspondence_cache.items())


def keep_correspondence(cache: dict) -> None:
    for key, value in cache.items():
        _correspondence_cache.put(key, value)


@dataclass
class ResolveJob:
    """What a resolve read from the scene: core can run on it without touching bpy."""

    body: object
    garments: list
    arrays: list
    params: dict
    source: str
    key: tuple
    reuse_correspondence: bool
    read_s: float
    t0: float
    scheme: str
    parts_known: bool
    made_for: list  # per garment, what its result is made for (staleness.fingerprint)
    hide_skin: bool = False
    body_made_for: str = ""


def prepare_resolve(scene, reuse_correspondence=False) -> ResolveJob:
    """Read and check the scene (main thread)."""
    settings = scene.deformrt
    t0 = time.perf_counter()
    body, garments, arrays, parts, source, g_parts, g_normals = read_scene(scene, settings.scheme,
                                                                          playing=reuse_correspondence)
    if len(garments) < 2:
        raise LayeringInputError(f"Only one garment ({garments[0].name}): nothing is worn over it, nothing to resolve")
    for obj, a in zip([body, *garments], arrays, strict=True):
        if not len(a.triangles):
            raise LayeringInputError(f"{obj.name} has no faces after its modifiers")
    params = {"boundary_pass": settings.boundary_pass, "body_guard": settings.body_guard,
              "remove_hidden": settings.remove_hidden}
    if settings.offset > 0:
        params["offset"] = settings.offset
    probe = probe_distances(settings, parts is not None)
    if probe is not None:
        params["probe_distance"] = probe
    shells = [result_stack.outward_shell(g) for g in garments]
    if any(shells):
        params["outward_shells"] = shells
    if settings.scheme == "NONE":
        params["segment_links"] = True  # the body's separate pieces are still one body
    if parts is not None:
        params.update(body_segments=parts, scheme=settings.scheme)
        if any(p is not None for p in g_parts):
            params["garment_segments"] = g_parts
    if any(n is not None for n in g_normals):
        params["global_normals"] = g_normals
    key = _topology_key([body, *garments], arrays)
    last = _last_frame.get(key) if reuse_correspondence else None
    if last is not None and abs(scene.frame_current - last[0]) == 1:  # the frame next to it: playback
        params["previous"] = last[1]
        # body points carried from the last frame; the kept ones fill in for a garment it did not trace
        if key in _correspondence_cache:
            params["correspondence"] = _correspondence_cache.get(key)
    # after a jump (or on the first frame) the body is searched afresh: a frame looks the same
    # whichever frame one came from, and a bake of a range holds what playing it shows
    prints = {}  # the body's read once
    made_for = [staleness.fingerprint(g, body, prints) for g in garments]
    return ResolveJob(body, garments, arrays, params, source, key, reuse_correspondence,
                      time.perf_counter() - t0, t0, settings.scheme, parts is not None, made_for,
                      settings.hide_covered_skin, staleness.fingerprint(body, body, prints))


def compute_resolve(job: ResolveJob):
    """The core resolve: no bpy, safe to run on a worker thread."""
    return resolve_layers(_trimesh(job.arrays[0]), [_trimesh(a) for a in job.arrays[1:]], **job.params)


def _write_covered_skin(scene, job: ResolveJob, result) -> int:
    """With Hide Covered Skin, the body's faces the garments cover all over are left out by a
    result of the body's own (no moves); without, the body shows whole. Returns how many."""
    body, a = job.body, job.arrays[0]
    if not job.hide_skin:
        results.clear(body)
        return 0
    worn = [(g.vertices, g.faces) for g in result.garments]
    # skin can only show through cloth that lies close on it: within three gaps between layers out,
    # or one in (under a collar that stands off the neck the skin stays, else one sees into the
    # garment); and the skin within 1% of the body's size (2 cm on a person) of an opening stays
    gap = result.stats["gap"]
    size = size_of(a.vertices)
    body_faces = a.triangles[:, ::-1] if result.stats.get("body_inside_out") else a.triangles  # as the resolve took it
    covered = covered_faces(a.vertices, body_faces, worn, 3.0 * gap, gap, 0.01 * size)
    hidden = np.ones(a.n_polygons, dtype=bool)  # a polygon goes when every triangle of it is covered
    np.logical_and.at(hidden, a.triangle_polygon, covered)
    hidden &= np.bincount(a.triangle_polygon, minlength=a.n_polygons) > 0
    results.write(scene, body, np.zeros((len(a.vertices), 3)), hidden, made_for=job.body_made_for,
                  cage_local=_local(a))
    return int(hidden.sum())


def _local(a):
    """MeshArrays' world vertices back in their object's space."""
    m = a.matrix_world
    return (a.vertices - m[:3, 3]) @ np.linalg.inv(m[:3, :3]).T


def finish_resolve(scene, job: ResolveJob, result) -> ResolveSummary:
    """Show the result on the garments, non-destructively (main thread)."""
    normals, corr = result.found()  # garments the resolve did not trace need no body search
    if job.reuse_correspondence:
        kept = _correspondence_cache.get(job.key)
        if kept is None:
            _correspondence_cache.put(job.key, corr)  # one animation's: the last one's goes
        else:  # this frame's, carried and checked; a garment this frame did not trace keeps its last
            _correspondence_cache.put(job.key, [new if new is not None else c
                                                for c, new in zip(kept, corr, strict=True)])
        _last_frame.put(job.key, (scene.frame_current, result))
    garments, arrays = job.garments, job.arrays
    t1 = time.perf_counter()
    faces_hidden = []
    for obj, a, moved, removed, made_for in zip(garments, arrays[1:], result.moved, result.removed_faces,
                                                job.made_for, strict=True):
        to_local = np.linalg.inv(a.matrix_world[:3, :3])
        hidden = np.zeros(a.n_polygons, dtype=bool)
        hidden[a.triangle_polygon[removed]] = True
        faces_hidden.append(int(hidden.sum()))
        results.write(scene, obj, moved @ to_local.T, hidden, made_for=made_for, cage_local=_local(a))
    skin_hidden = _write_covered_skin(scene, job, result)
    write_s = time.perf_counter() - t1
    st = result.stats
    inward = []
    for obj, a, n in zip(garments, arrays[1:], normals, strict=True):
        if n is None:  # not traced: nothing moved, so no normal of it mattered
            continue
        corner = [rows(a.vertices, a.triangles[:, k]) for k in range(3)]
        facing = cross(corner[1] - corner[0], corner[2] - corner[0])
        out = np.einsum("ij,ij->i", facing, sum(rows(n, a.triangles[:, k]) for k in range(3)))
        if (out < 0).mean() > 0.5:
            inward.append(obj.name)
    summary = ResolveSummary(job.body.name, [g.name for g in garments], job.source, st,
                             [float(norms(m).max(initial=0.0)) for m in result.moved], faces_hidden,
                             {"read_s": job.read_s, "resolve_s": st["total_s"], "write_s": write_s,
                              "total_s": time.perf_counter() - job.t0}, inward,
                             alone=[g.name for g, t in zip(garments, result.traced, strict=True) if not t],
                             moved_after=[f"{g.name}'s {m}" for g in garments for m in result_stack.moving_after(g)],
                             skin_hidden=skin_hidden, length=scene_units.formatter(scene))
    if job.parts_known:
        summary.probe_by_part = dict(zip(get_scheme(job.scheme).parts, st["probe_distance"], strict=True))
    return summary


def resolve_scene(scene, progress=None, reuse_correspondence=False) -> ResolveSummary:
    """Resolve the scene's tagged garments and show the result on them (non-destructively).

    With ``reuse_correspondence`` (playback, frame bakes) a frame next to the last one resolved
    starts from it: its body points carried through the motion, its hidden faces held, its
    correction eased (core frame_coherence); any other frame is resolved afresh."""
    step = progress or (lambda _k: None)
    job = prepare_resolve(scene, reuse_correspondence)
    step(1)
    result = compute_resolve(job)
    step(2)
    summary = finish_resolve(scene, job, result)
    step(3)
    return summary


def clear_scene(scene) -> int:
    """Remove every garment's result; returns how many there were."""
    # data objects are removed on the way: collect the garments first
    wearing = [o for o in scene.objects if o.type == "MESH" and results.result_modifier(o) is not None]
    count = sum(results.clear(o) for o in wearing)
    return count + results.remove_unused_data()


def _write_parts(obj, parts, scheme):
    for group in [g for g in obj.vertex_groups if g.name.startswith(PART_GROUP_PREFIX)]:
        obj.vertex_groups.remove(group)
    present = np.unique(parts)
    onehot = (parts[:, None] == present[None, :]).astype(np.float64)
    mesh_io.write_vertex_groups(obj, [PART_GROUP_PREFIX + scheme.parts[p] for p in present], onehot)


def auto_segment(scene) -> str:
    """Write DRT_<part> vertex groups on the body and every garment (skirts found), from the
    body's rig groups or stored parts; the user can repaint them and the resolve honours them."""
    settings = scene.deformrt
    if settings.scheme == "NONE":
        raise LayeringInputError("Pick a part scheme (5 or 13 parts) to segment by")
    scheme = get_scheme(settings.scheme)
    body, garments = layered_objects(scene)
    with fitted_cages([body, *garments]):  # the body's own result (the covered skin left out) too
        depsgraph = bpy.context.evaluated_depsgraph_get()
        arrays = read_meshes([body, *garments], depsgraph)
        parts, source = body_parts(body, settings.scheme, arrays[0].vertices, painted_groups=False)
        if parts is None:
            raise LayeringInputError(f"{body.name} has no rig vertex groups or stored parts to segment by: "
                                     "paint DRT_<part> groups (DRT_torso, DRT_left_arm, ...) by hand")
        found = _correspondence_only(arrays, body_segments=parts, scheme=scheme)
        # checked for all before writing any: nothing is left half-segmented
        _check_own_vertices([body, *garments], arrays, "part groups need the mesh's own vertices; apply them "
                            "or paint DRT_<part> groups by hand")
        _write_parts(body, parts, scheme)
        for obj, seg in zip(garments, found.segments, strict=True):
            _write_parts(obj, seg, scheme)
    skirts = [garments[i].name for i in found.skirts]
    return (f"Segmented {body.name} and {len(garments)} garments into {scheme.name} parts from {source}"
            + (f"; skirts: {', '.join(skirts)}" if skirts else ""))


def inspect_scene(scene) -> LayersReport:
    """Crossings, poke-through and distortion of the tagged layers as fitted and as shown now."""
    body, garments = layered_objects(scene)
    objs = [body, *garments]
    stale = staleness.check_scene(scene)
    with results_bypassed(garments):
        depsgraph = bpy.context.evaluated_depsgraph_get()
        fitted = read_meshes(objs, depsgraph)
    with fitted_cages(garments):
        cages = read_meshes(garments, bpy.context.evaluated_depsgraph_get())
    depsgraph = bpy.context.evaluated_depsgraph_get()
    now = read_meshes(objs, depsgraph)
    before = [(a.vertices, a.triangles) for a in fitted]
    after = [(a.vertices, a.triangles) for a in now]
    cameras = metrics.camera_ring(*metrics.layer_bounds(before), views=8, resolution=96)
    crossing_after = metrics.layer_crossings(after)
    names = [o.name for o in objs]
    report = LayersReport(
        kind="inspect", message="",
        crossings_before=int(np.triu(metrics.layer_crossings(before)).sum()),
        crossings_after=int(np.triu(crossing_after).sum()),
        still_crossing=[[names[i], names[j], int(crossing_after[i, j])]
                        for i, j in zip(*np.nonzero(np.triu(crossing_after)), strict=True)],
        poke_through_before=metrics.poke_through(before, cameras=cameras)[0],
        poke_through_after=metrics.poke_through(after, cameras=cameras)[0],
        stale=[[g.name, reason] for g, reason in stale])
    for obj, a in zip(garments, cages, strict=True):
        off = results.read_offsets(obj, len(a.vertices))
        if off is None or any(g == obj for g, _ in stale):
            continue
        d = metrics.distortion(a.vertices, a.vertices + off @ a.matrix_world[:3, :3].T, a.triangles)
        report.max_move_m = max(report.max_move_m, d["max_move"])
        if d["max_stretch"] > report.max_stretch:
            report.max_stretch, worst = d["max_stretch"], (obj.name, d["p99_stretch"])
    stretch = f"max edge stretch {report.max_stretch:.2f}x"
    if report.max_stretch > 1.0:  # where, and whether it is a few edges (a seam pulled in) or the cloth
        stretch += f" on {worst[0]} (99% of its edges {worst[1]:.2f}x or less)"
    report.message = (f"Crossing edges {report.crossings_before:,} -> {report.crossings_after:,}, "
                      f"poke-through {100 * report.poke_through_before:.2f}% -> "
                      f"{100 * report.poke_through_after:.2f}%, "
                      f"max move {scene_units.length(scene, report.max_move_m)}, {stretch}")
    if stale:
        report.message += f"; out of date, shown as fitted: {', '.join(g.name for g, _ in stale)}"
    return report


def transfer_normals(scene) -> str:
    """Store each garment's global normals (the normal of the nearest body point, or the skirt
    hull's) as a vector attribute the resolve then uses, plus a colour attribute to see them."""
    settings = scene.deformrt
    body, garments, arrays, parts, _, g_parts, _ = read_scene(scene, settings.scheme)
    _check_own_vertices(garments, arrays[1:], "apply them first")
    params = {}
    if parts is not None:
        params.update(body_segments=parts, scheme=settings.scheme, garment_segments=g_parts)
    found = _correspondence_only(arrays, **params)
    for obj, a, n in zip(garments, arrays[1:], found.global_normals, strict=True):
        local = n @ a.matrix_world[:3, :3]  # the inverse of the read's turn
        local /= np.maximum(np.linalg.norm(local, axis=1, keepdims=True), 1e-30)
        mesh_io.write_point_vectors(obj, GLOBAL_NORMAL_ATTRIBUTE, local, GLOBAL_NORMAL_COLOR)
    return (f"Stored global normals on {len(garments)} garments as '{GLOBAL_NORMAL_ATTRIBUTE}' (see them: Solid "
            f"shading, Color: Attribute, '{GLOBAL_NORMAL_COLOR}'); the resolve follows them until removed")


def remove_normals(scene) -> int:
    count = 0
    for obj in scene_roles.garments(scene):
        for name in (GLOBAL_NORMAL_ATTRIBUTE, GLOBAL_NORMAL_COLOR):
            attr = obj.data.attributes.get(name)
            if attr is not None:
                obj.data.attributes.remove(attr)
                count += 1
    return count
