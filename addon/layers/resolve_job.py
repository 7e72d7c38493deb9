"""The resolve as a job: read and check the scene once (main thread), compute everything in core
without bpy (a worker thread may run it), write the results once (main thread). Used by the
operators, the frame-change handler, frame bakes and the command line, so all of them check the
scene the same way and leave the same non-destructive result."""

import time
from dataclasses import dataclass, field

import numpy as np

from ...core.geometry.vectors import cross, inverse3, matmul3, norms, rows
from ...core.layering.covered_skin import covered_faces
from ...core.layering.resolve import resolve_layers
from ...core.layering.segmentation import get_scheme
from ..io import scene_units
from . import frame_memory, result_stack, results, staleness
from .report import LayersReport
from .scene_read import LayeringInputError, as_trimesh, probe_distances, read_scene


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


@dataclass
class ResolveJob:
    """What a resolve read from the scene: core can run on it without touching bpy."""

    body: object
    garments: list
    arrays: list  # MeshArrays, the body's first
    params: dict  # resolve_layers' keywords
    parts_source: str
    key: tuple  # frame_memory's key for these meshes
    playing: bool  # frame after frame: what it finds is kept for the next frame
    frame: int
    scheme: str
    parts_known: bool
    made_for: list  # per garment, what its result is made for (staleness.fingerprint)
    hide_skin: bool
    body_made_for: str
    read_s: float
    t0: float
    step: int = 1  # playback resolving every step-th frame: the frames between show these offsets (0: as many
    # as a resolve in the background takes, frame_handler)


@dataclass
class ResolveOutput:
    """All a job computed: core's result, the body's polygons the cloth covers (Hide Covered Skin,
    else None), the garments whose faces mostly face the body, and how long the computing took."""

    result: object
    skin_hidden: object
    inward: list
    compute_s: float


def _params(settings, scene_read) -> dict:
    """resolve_layers' keywords from the panel's settings and what was read."""
    # a shell grown inward after the correction lies behind the garment's surface, and the lower layer's
    # triangles it crosses are hidden; lifted clear of the surface only, they would cross the shell
    params = {"boundary_pass": settings.boundary_pass, "body_guard": settings.body_guard,
              "outer_room": settings.outer_room and not any(result_stack.shelled(g) for g in scene_read.garments),
              "remove_hidden": settings.remove_hidden}
    if settings.offset > 0:
        params["offset"] = settings.offset
    probe = probe_distances(settings, scene_read.parts is not None)
    if probe is not None:
        params["probe_distance"] = probe
    shells = [result_stack.outward_shell(g) for g in scene_read.garments]
    if any(shells):
        params["outward_shells"] = shells
    solved = [result_stack.simulated(g) for g in scene_read.garments]
    if any(solved):
        params["simulated"] = solved
    smoothed = [result_stack.subdivided(g) for g in scene_read.garments]
    if any(smoothed):
        params["subdivided"] = smoothed
    if settings.scheme == "NONE":
        params["segment_links"] = True  # the body's separate pieces are still one body
    if scene_read.parts is not None:
        params.update(body_segments=scene_read.parts, scheme=settings.scheme)
        if any(p is not None for p in scene_read.garment_parts):
            params["garment_segments"] = scene_read.garment_parts
    if any(n is not None for n in scene_read.garment_normals):
        params["global_normals"] = scene_read.garment_normals
    return params


def prepare_resolve(scene, playing=False, step=1, reach=None) -> ResolveJob:
    """Read and check the scene (main thread). ``playing`` (playback, frame bakes): a frame next to
    the last one resolved (``reach`` frames away or nearer, by default ``step``) starts from it
    (frame_memory)."""
    settings = scene.deformrt
    t0 = time.perf_counter()
    read = read_scene(scene, settings.scheme, playing=playing)
    if len(read.garments) < 2:
        raise LayeringInputError(f"Only one garment ({read.garments[0].name}): nothing is worn over it, "
                                 "nothing to resolve")
    for obj, a in zip([read.body, *read.garments], read.arrays, strict=True):
        if not len(a.triangles):
            raise LayeringInputError(f"{obj.name} has no faces after its modifiers")
    params = _params(settings, read)
    key = frame_memory.topology_key([read.body, *read.garments], read.arrays)
    if playing:
        params.update(frame_memory.carried(key, scene.frame_current, reach or step))
    prints = {}  # the body's read once
    made_for = [staleness.fingerprint(g, read.body, prints) for g in read.garments]
    body_made_for = staleness.fingerprint(read.body, read.body, prints)
    return ResolveJob(body=read.body, garments=read.garments, arrays=read.arrays, params=params,
                      parts_source=read.parts_source, key=key, playing=playing, frame=scene.frame_current,
                      scheme=settings.scheme, parts_known=read.parts is not None, made_for=made_for,
                      hide_skin=settings.hide_covered_skin, body_made_for=body_made_for,
                      read_s=time.perf_counter() - t0, t0=t0, step=step)


def compute_resolve(job: ResolveJob) -> ResolveOutput:
    """Everything the resolve computes: no bpy, safe to run on a worker thread."""
    t0 = time.perf_counter()
    result = resolve_layers(as_trimesh(job.arrays[0]), [as_trimesh(a) for a in job.arrays[1:]], **job.params)
    skin = _covered_skin(job.arrays[0], result) if job.hide_skin else None
    inward = [g.name for g, a, n in zip(job.garments, job.arrays[1:], result.found()[0], strict=True)
              if n is not None and _faces_inward(a, n)]
    return ResolveOutput(result, skin, inward, time.perf_counter() - t0)


def _covered_skin(a, result):
    """The body's polygons every triangle of which the garments cover (Hide Covered Skin)."""
    worn = [(g.vertices, g.faces) for g in result.garments]
    # skin can only show through cloth that lies close on it: within three gaps between layers out,
    # or one in (under a collar that stands off the neck the skin stays, else one sees into the
    # garment); and the skin within 1% of the body's size (2 cm on a person) of an opening stays
    gap = result.stats["gap"]
    body_faces = a.triangles[:, ::-1] if result.stats.get("body_inside_out") else a.triangles  # as the resolve took it
    covered = covered_faces(a.vertices, body_faces, worn, 3.0 * gap, gap, 0.01 * result.stats["body_size"],
                            normals=result.history.body_normals)  # the resolve's, of these faces
    hidden = np.ones(a.n_polygons, dtype=bool)  # a polygon goes when every triangle of it is covered
    np.logical_and.at(hidden, a.triangle_polygon, covered)
    hidden &= np.bincount(a.triangle_polygon, minlength=a.n_polygons) > 0
    return hidden


def _faces_inward(a, normals) -> bool:
    """Whether most of a garment's triangles face against its global normals (toward the body)."""
    corner = [rows(a.vertices, a.triangles[:, k]) for k in range(3)]
    facing = cross(corner[1] - corner[0], corner[2] - corner[0])
    out = np.einsum("ij,ij->i", facing, sum(rows(normals, a.triangles[:, k]) for k in range(3)))
    return bool((out < 0).mean() > 0.5)


def _local(a):
    """MeshArrays' world vertices back in their object's space."""
    m = a.matrix_world
    return matmul3(a.vertices - m[:3, 3], inverse3(m[:3, :3]).T)


def finish_resolve(scene, job: ResolveJob, output: ResolveOutput) -> ResolveSummary:
    """Show the result on the garments, non-destructively (main thread): writes only."""
    result = output.result
    if job.playing:
        frame_memory.remember(job.key, job.frame, result)
    t1 = time.perf_counter()
    faces_hidden = []
    for obj, a, moved, removed, made_for in zip(job.garments, job.arrays[1:], result.moved, result.removed_faces,
                                                job.made_for, strict=True):
        to_local = inverse3(a.matrix_world[:3, :3])
        hidden = np.zeros(a.n_polygons, dtype=bool)
        hidden[a.triangle_polygon[removed]] = True
        faces_hidden.append(int(hidden.sum()))
        # no cage while playback leaves frames to this result: they show it on poses it was not made for
        cage = _local(a) if job.step == 1 else None
        results.write(scene, obj, results.Shown(matmul3(moved, to_local.T), hidden, made_for=made_for, cage=cage))
    if output.skin_hidden is None:  # without Hide Covered Skin the body shows whole
        results.clear(job.body)
    else:  # a result of the body's own, no moves
        body = job.arrays[0]
        results.write(scene, job.body, results.Shown(np.zeros((len(body.vertices), 3)), output.skin_hidden,
                                                     made_for=job.body_made_for,
                                                     cage=_local(body) if job.step == 1 else None))
    write_s = time.perf_counter() - t1
    st = result.stats
    garments = job.garments
    summary = ResolveSummary(job.body.name, [g.name for g in garments], job.parts_source, st,
                             [float(norms(m).max(initial=0.0)) for m in result.moved], faces_hidden,
                             {"read_s": job.read_s, "resolve_s": st["total_s"], "compute_s": output.compute_s,
                              "write_s": write_s, "total_s": time.perf_counter() - job.t0}, output.inward,
                             alone=[g.name for g, t in zip(garments, result.traced, strict=True) if not t],
                             moved_after=[f"{g.name}'s {m}" for g in garments for m in result_stack.moving_after(g)],
                             skin_hidden=0 if output.skin_hidden is None else int(output.skin_hidden.sum()),
                             length=scene_units.formatter(scene))
    if job.parts_known:
        summary.probe_by_part = dict(zip(get_scheme(job.scheme).parts, st["probe_distance"], strict=True))
    return summary


def resolve_scene(scene, progress=None, playing=False, step=1, reach=None) -> ResolveSummary:
    """Resolve the scene's tagged garments and show the result on them (non-destructively).

    ``playing`` (playback, frame bakes): a frame next to the last one resolved starts from it: its
    body points carried through the motion, its hidden faces held, its correction eased (core
    frame_coherence); any other frame is resolved afresh. ``step`` > 1: playback resolves every
    step-th frame and the frames between show this result (no cage check, frame_handler). ``reach``:
    how many frames back the last resolve may be for this frame to start from it (``step`` if None;
    viewport playback may drop frames, frame_handler)."""
    tick = progress or (lambda _k: None)
    job = prepare_resolve(scene, playing, step, reach)
    tick(1)
    output = compute_resolve(job)
    tick(2)
    summary = finish_resolve(scene, job, output)
    tick(3)
    return summary


def clear_scene(scene) -> int:
    """Remove every garment's result; returns how many there were."""
    # data objects are removed on the way: collect the garments first
    wearing = [o for o in scene.objects if o.type == "MESH" and results.result_modifier(o) is not None]
    count = sum(results.clear(o) for o in wearing)
    return count + results.remove_unused_data()
