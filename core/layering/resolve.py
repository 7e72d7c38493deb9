"""Resolve layered garments so lower layers stay behind higher ones (thesis ch. 4, 4.3-4.4).

Stages, in the thesis' order: correspondence and global normals (pre-processing), the
boundary pass (smooth tuck-in of lower layers under higher layers' hems, Fig. 4.10),
push-behind (layered ray tracing for mesh deformation), hidden-face removal (Fig. 4.14).
The middle two run layer by layer, outer to inner, so each layer is fitted to the higher
layers where they end up.
Inputs are never modified; every stage works on copies.
"""

from __future__ import annotations

import time

import numpy as np
import trimesh

from ..geometry.vectors import norms
from .body_facts import body_facts
from .body_guard import keep_clear_cloth_clear, keep_out_of_body
from .body_lift import lift_off_body
from .boundary_pass import tuck_under_hems
from .frame_coherence import BodyNow, History, eased, held_hidden
from .garment_prep import GarmentPrep
from .hidden_faces import crossing_faces
from .layer_stack import LayerStack
from .outer_room import make_room
from .parameters import LayeringParameters, check_known, inside_out, read_meshes
from .probes import probe_reach, widened
from .push_behind import push_behind
from .result import FoundOnBody, LayeringResult
from .stretch_relax import MAX_TORN, relax_stretch, shorten_torn


def resolve_layers(body, garments, body_segments=None, previous=None, **params) -> LayeringResult:
    """Move lower garment layers behind higher ones and drop triangles that still show through.

    body, garments: trimesh.Trimesh in world space, garments ordered inner to outer. A
        garment that comes near no other (see LayeringResult.traced) is returned as it is
        without any work, the body search included. What a resolve finds for a garment
        before moving anything (body points, global normals, parts) is kept with the body's
        facts under the content of all it came from: resolving the same garments again with
        another offset, falloff or stage switch skips it (stats["garments_kept"]), and the
        ray scenes of the garments as they came are kept too (core.scene_cache,
        stats["scenes_kept"]): a layer nothing moves builds no BVH the next time.
    body_segments: optional int per body vertex (body part ids); garment vertices take
        the part of their nearest body point and only meet triangles of the same part.
        Without it, each connected piece of the body mesh is a part.
    params:
        offset (d, scene units): gap left behind a higher layer; default 0.1% of the
            body's size (the diagonal of its box in its own axes, at most what a standing figure
            of its skin's area spans: about 2 mm on a 1.8 m figure, in any pose;
            parameters.body_size).
        probe_distance (l_s): scalar, or one value per segment id (NaN: that part's
            default). Default: with
            body_segments, each part's median local radius (half the chord through the
            body); without, the local radius at each garment vertex's nearest body point.
        scheme: "S5", "S13" or a segmentation.Scheme naming the body_segments ids. With it, a
            garment whose hem goes round both legs (skirt, dress) has its leg points put in the
            skirt segment, traced against the torso and both legs, with normals from the
            convex hull of those parts.
        segment_links: (S, S) bool, which segments' triangles each segment's rays meet;
            default each segment itself (and the skirt links of the scheme); True links all.
        garment_segments: list of per-vertex segment arrays (or None) overriding the nearest-body rule.
        global_normals: list of per-vertex (n,3) arrays (or None) overriding the body's normals.
        correspondence: list of BodyCorrespondence (or None) from an earlier call on the same
            garment topology (e.g. the rest pose), carried through the body's deformation
            instead of searching again (searched again only where a point drifted off:
            garment_prep.carried).
    previous: the LayeringResult of the last frame of the same body and garments (playback,
        a frame bake). Its body points, carried and checked frame by frame, are used before
        ``correspondence``'s, and a face it hid stays hidden HIDE_HOLD frames after it last
        crossed (no face blinks for one frame).
        segment_margin: garment points within sqrt(2) times their body distance plus this
            much of a place where their part meets another (a junction on the body) also trace
            against that part; default 1% of the body's size (about 2 cm on a person), 0 for strict parts.
        boundary_pass, push_behind, body_guard, outer_room, remove_hidden: bool stages, all on by
            default. The outer room stage (core.outer_room) moves a higher layer's edges out
            where they still pass through a lower layer the body holds.
            The body guard takes back moves that put cloth through the body (core.body_guard):
            a body with no sharp edges (a smooth scan) rarely needs it.
        falloff: Gaussian radius c of the boundary pass's spread, scene units; default
            4 mean edge lengths of the lower layer.
        outward_shells: per garment, how far it grows outward after the resolve (scene units;
            a Solidify that runs after the correction): the gap d grows by the thickest of a
            lower layer's, so no shell shows through the next layer. A shell grown inward needs
            no room: it lies behind its own garment's surface, which hides what it crosses
            (measured on Fig 4.13 with 1 cm Solidify after Subdivision: making room for inward
            shells too pushes the layers against the body and doubles poke-through).
        simulated: per garment, whether its cloth is simulated (a cloth solver's, whose
            contacts come and go from frame to frame, the body its collider) rather than
            skinned: frame after frame its crossing faces are hidden every frame they cross
            (frame_coherence.held_hidden), and neither its lift nor its easing may put it
            through the body (_guarded).
        subdivided: per garment, whether a Subdivision Surface smooths it after the correction: the
            outer room stage then lifts a ring wider, so the smoothed bump still clears the layer
            under it (core.layering.outer_room).
    """
    t_start = time.perf_counter()
    timings = {}
    check_known(params)
    body_vertices, body_faces, garment_arrays = read_meshes(body, garments)
    previous, params = _carried_in(previous, garment_arrays, params)
    flipped = inside_out(body_vertices, body_faces)
    if flipped:
        body_faces = body_faces[:, ::-1]  # resolved as the body it is: the result is the same either way
    facts = body_facts(body_vertices, body_faces)
    if previous is not None:
        facts.carry_radius(previous.body_radius)
        facts.carry_junctions(previous.body_junctions)
    p = LayeringParameters.parse(facts, body_vertices, body_faces, garment_arrays, body_segments, params)

    t0 = time.perf_counter()
    reach = probe_reach(facts, p)
    prep = GarmentPrep(facts, garment_arrays, p, reach)
    reach = widened(reach, prep, p, p.gap)
    timings["correspondence_s"] = time.perf_counter() - t0

    stack = LayerStack(facts, garment_arrays, prep, p)
    lifts = _lift(stack, prep, previous, timings)
    _fit_layers(stack, timings)
    if p.outer_room:
        t0 = time.perf_counter()
        make_room(stack)
        timings["outer_room_s"] = time.perf_counter() - t0
    _shorten_torn(stack)
    body_turn = facts.normals  # how the cloth turned since: as the body under each point did
    n_eased, eased_most, eased_past_gap = _ease(stack, garment_arrays, prep, previous, p.offset, body_turn)
    t0 = time.perf_counter()
    removed = _hidden_faces(stack) if p.remove_hidden else [np.zeros(len(f), dtype=bool) for f in stack.faces]
    last = previous if p.remove_hidden else None
    removed, clear, shown = held_hidden(removed, last and last.removed_faces, last and last.frames_clear,
                                        last and last.frames_shown, p.simulated)
    timings["hidden_faces_s"] = time.perf_counter() - t0

    out, moved = [], []
    for i, (v0, _) in enumerate(garment_arrays):
        moved.append(stack.verts[i] - v0)
        # a mask's gather is slower than a copy where nothing was removed
        kept_faces = stack.faces[i][~removed[i]] if removed[i].any() else stack.faces[i].copy()
        out.append(trimesh.Trimesh(stack.verts[i], kept_faces, process=False, validate=False))
    timings["total_s"] = time.perf_counter() - t_start
    found = FoundOnBody(prep.traced, prep.normals, prep.corr, prep.vseg, prep.skirts,
                        prep.complete if len(prep.active) < len(garment_arrays) else None)
    result = LayeringResult(out, moved, removed, {**_stats(stack, prep, reach, removed, timings),
                                                  "body_inside_out": flipped, "vertices_eased": n_eased,
                                                  "eased_most": eased_most, "eased_past_gap": eased_past_gap}, found)
    # what the next frame carries on from (playback, frame bakes)
    result.frames_clear, result.frames_shown = clear, shown
    result.lifts = lifts
    result.history = History(moved, [v for v, _ in garment_arrays], body_turn,
                             previous.history if previous is not None else None, stack.body.vertices)
    result.body_radius = facts.radius_found
    result.body_junctions = facts.junctions_found()
    return result


def _carried_in(previous, garment_arrays, params):
    """(``previous`` if it is a result for these garments, else None; ``params`` with its body
    points filling in where no correspondence was given)."""
    previous = previous if _same_garments(previous, garment_arrays) else None
    if previous is not None:
        given = list(params.get("correspondence") or [None] * len(garment_arrays))
        params = {**params, "correspondence": [c if c is not None else g
                                                for c, g in zip(previous.found()[1], given, strict=True)]}
    return previous, params


def _lift(stack, prep, previous, timings) -> list:
    """Every layer that takes part lifted off the body (body_lift) and its torn edges drawn back;
    per garment the lift (None for one that does not take part)."""
    t0 = time.perf_counter()
    lifts = [None] * len(stack.verts)
    held = (previous.lifts if previous is not None else None) or [None] * len(stack.verts)
    for k in stack.active:
        came, clear = stack.verts[k], stack.clearance[k].copy() if _guarded(stack, k) else None
        lifts[k] = lift_off_body(stack, k, prep.corr[k].distance, held[k])
        if clear is not None and stack.verts[k] is not came:
            _guard_lift(stack, k, came, clear)
        _relax(stack, k)
        stack.rest[k] = stack.verts[k]  # what the body guard takes moves back to: the stages' moves, not the lift
    timings["lift_s"] = time.perf_counter() - t0
    return lifts


def _guarded(stack, k) -> bool:
    """Whether layer k's lift and easing are kept out of the body too: on a simulated garment (a
    cloth solver's, whose collider is the body: sheets falling onto a stage). Skinned cloth lies in
    its body at creases wherever the skinning puts it there; the lift takes it out and easing holds
    it, and guarding either took back what they were for (a walk's poke-through 0.00 -> 0.13%, its
    jitter max 4.2 -> 43 mm)."""
    return stack.params.body_guard and stack.params.simulated[k]


def _guard_lift(stack, k, came, clear) -> None:
    """The body guard on layer k's lift (body_guard.back_off from where it came, ``clear`` its
    clearances there): a lift along global normals that diverge over a convex part of the body (a
    box's ridge, a sphere under long edges of cloth) can put an edge or triangle through it that
    went clear before. Only those are taken back: cloth lifted out of the body but still partly in
    it keeps its lift."""
    lifted = stack.verts[k]
    # the clearances the lift wrote assume a move along the normal goes straight away from the body,
    # which is what fails here: every moved edge and triangle is asked
    kept_out, n_back = keep_clear_cloth_clear(stack, k, came, lifted, np.zeros(len(lifted)))
    if n_back:
        back = (kept_out != lifted).any(axis=1)
        stack.clearance[k][back] = clear[back]  # a lower bound where it came from holds part of the way back
        stack.moved(k, kept_out)


def _shorten_torn(stack) -> None:
    """What push and tuck tore (ends pushed along diverging normals), drawn in."""
    for k in stack.active:
        out, drawn = shorten_torn(stack.fitted[k], stack.verts[k], stack.edges[k], MAX_TORN)
        if drawn:
            stack.moved(k, out)
            stack.moved_by["relaxed"] += drawn


def _ease(stack, garment_arrays, prep, previous, offset, body_turn) -> tuple[int, float, int]:
    """No jolt from the last frames (frame_coherence.eased): how many vertices were eased, the
    farthest one was left from where this frame alone put it, and how many were left farther than
    the gap between layers (where a lower layer may show through for a frame or two)."""
    if previous is None or previous.history is None:
        return 0, 0.0, 0
    count, most, past = 0, 0.0, 0
    for k in stack.active:
        smoothed, n = eased(stack.verts[k], garment_arrays[k][0], k, previous.history, offset,
                            BodyNow(prep.corr[k], body_turn, stack.body.faces, stack.body.vertices))
        if n:
            own = stack.verts[k]
            if _guarded(stack, k):
                smoothed = _guard_ease(stack, k, own, smoothed)
            left = norms(smoothed - own)
            count, most, past = count + n, max(most, float(left.max())), past + int((left > stack.gap).sum())
            stack.moved(k, smoothed)
    return count, most, past


def _guard_ease(stack, k, own, smoothed):
    """Layer k eased from where this frame put it (``own``, clear of the body) to ``smoothed``, with
    the easing that puts cloth through the body taken back towards ``own`` (body_guard.back_off): a
    correction held from the last frames where the body has just moved under the cloth (cloth
    landing on a collider) would push it in. A vertex eased by m from ``own`` is at least its
    clearance less m from the body: only edges and triangles that can reach it are asked (all of
    them where the body points came from the last frame: guard_clearance)."""
    clearance = np.maximum(stack.guard_clearance(k) - norms(smoothed - own), 0.0)
    return keep_clear_cloth_clear(stack, k, own, smoothed, clearance)[0]


def _same_garments(previous, garment_arrays) -> bool:
    """Whether ``previous`` is a result for garments of these vertex and face counts."""
    if previous is None:
        return False
    moved, removed = previous.moved, previous.removed_faces
    return len(moved) == len(garment_arrays) and all(len(m) == len(v) and len(r) == len(f)
                                           for m, r, (v, f) in zip(moved, removed, garment_arrays, strict=True))


def _fit_layers(stack, timings) -> None:
    """Outer to inner, each lower layer is tucked under, then pushed behind, higher layers where
    they end up (a higher layer moved after a lower one was fitted to it would undo the fit),
    then kept out of the body."""
    p = stack.params
    timings["boundary_pass_s"] = timings["push_behind_s"] = timings["body_guard_s"] = 0.0
    for k in stack.active[-2::-1]:
        t0 = time.perf_counter()
        if p.boundary_pass:
            tuck_under_hems(stack, k)
        t1 = time.perf_counter()
        if p.push_behind:
            push_behind(stack, k)
        t2 = time.perf_counter()
        if p.body_guard:
            keep_out_of_body(stack, k)
        timings["boundary_pass_s"] += t1 - t0
        timings["push_behind_s"] += t2 - t1
        timings["body_guard_s"] += time.perf_counter() - t2


def _relax(stack, k) -> None:
    """Edges of layer k the lift pulled apart beyond MAX_STRETCH drawn back (stretch_relax), before
    any layer is fitted to it. Only the lift's: drawing together what push and tuck moved draws
    lower cloth back out where it was pushed in (Fig 4.12: poke-through 0.01% -> 0.13% at 2.5x,
    0.07% even at 2.9x)."""
    out, drawn = relax_stretch(stack.fitted[k], stack.verts[k], stack.edges[k])
    if drawn:
        stack.moved(k, out)
        stack.moved_by["relaxed"] += drawn


def _hidden_faces(stack) -> list:
    """Hidden-face removal (Fig. 4.14): per garment, the triangles still crossing a higher layer."""
    active = stack.active
    removed = [np.zeros(len(f), dtype=bool) for f in stack.faces]
    # a layer's last scene is over where it ended up (each move builds anew): traced again here
    built = [stack.scenes[i].built_full() if stack.scenes[i].vertices is stack.verts[i] else None for i in active]
    masks, stack.rays["hidden"] = crossing_faces([stack.verts[i] for i in active], [stack.faces[i] for i in active],
                                                 [stack.edges[i] for i in active], built)
    for i, mask in zip(active, masks, strict=True):
        removed[i] = mask
    return removed


def _far_and_hidden(stack, prep, removed) -> int:
    """Vertices of lower layers farther from the body than their probe reaches that lie on a
    face the resolve had to hide: where the method's known limit (an unprobed point cannot be
    pushed behind what is over it) showed. Loose cloth beyond the reach that nothing crosses, and
    the outermost layer (it sends no probe), are no concern."""
    count = 0
    for i in stack.active[:-1]:
        far = prep.corr[i].distance > stack.probe_len[i]
        if far.any() and removed[i].any():
            on_hidden = np.zeros(len(far), dtype=bool)
            on_hidden[stack.faces[i][removed[i]].ravel()] = True
            count += int((far & on_hidden).sum())
    return count


def _stats(stack, prep, reach, removed, timings) -> dict:
    p, active = stack.params, stack.active
    return {
        **timings,
        "garments": stack.n_garments,
        "segments": p.n_segments,
        "segments_traced": 1 if p.one_part else p.n_segments,
        "scheme": p.scheme.name if p.scheme is not None else None,
        "skirts": list(prep.skirts),
        "offset": p.offset,
        "body_size": p.diagonal,  # the default offset's measure (parameters.body_size)
        "gap": stack.gap,  # the offset, outward shells and the tessellation allowance
        "probe_distance": reach.per_segment.tolist(),
        "probe_distance_per_vertex": bool(reach.local),
        "rays_boundary": stack.rays["boundary"],
        "rays_push": stack.rays["push"],
        "push_trace_s": stack.push_trace_s,
        "rays_hidden": stack.rays["hidden"],
        "vertices_lifted_off_body": stack.moved_by["lift"],
        "vertices_moved_boundary": stack.moved_by["boundary"],
        "vertices_moved_push": stack.moved_by["push"],
        "vertices_moved_room": stack.moved_by["room"],
        "vertices_held_by_body": stack.floor_clamped,
        "vertices_kept_out_of_body": stack.backed_off,
        "vertices_relaxed": stack.moved_by["relaxed"],
        "faces_removed": int(sum(r.sum() for r in removed)),
        "vertices_beyond_probe": prep.far,
        "vertices_far_from_body": _far_and_hidden(stack, prep, removed),
        "vertices_on_part_borders": int(sum((stack.junction_parts[i][:, 1] >= 0).sum() for i in active)),
        "scenes_built": stack.scenes_built(),
        "scenes_kept": stack.scenes_kept(),
        "garments_traced": len(active),
        "garments_kept": len(prep.reused),  # pre-processing found in an earlier resolve of the same garment
    }


__all__ = ["LayeringResult", "resolve_layers"]
