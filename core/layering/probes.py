"""How far probe rays look (l_s, thesis Fig. 4.5) and which body part's triangles they meet: one
rule for the resolve (``probe_reach``, ``widened``) and for the DeformRT Layered render engine
(``body_probes``), both widening a part's reach where loose cloth hangs (``widen``). Both take
each part's l_s from BodyFacts.probe_lengths (the part's median radius, a skirt's its linked
parts' farthest, overrides per part) or, without parts, the body's radius under each point; and
both read a point's part and radius where its nearest body surface point is (``part_at``,
``radius_at``): the resolve for the garment points it finds once and keeps, the engine for every
object of a frame (in a cache of its own, BodyFacts.nearest_kept, for the next frame of a still
object)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..geometry.keys import digest
from .body_facts import body_facts, frozen
from .correspondence import nearest_on_surface
from .parameters import OFFSET_SHARE, body_size
from .segmentation import get_scheme, is_skirt, skirt_segments


def part_at(corr, body_faces, body_parts):
    """(Each point's body part, the body vertex it is read at): the part of the corner of its
    nearest body triangle that its nearest point lies closest to (the largest barycentric
    weight). ``corr`` a BodyCorrespondence."""
    corner = body_faces[corr.triangle, np.argmax(corr.bary, axis=1)]
    return body_parts[corner], corner


def radius_at(corr, body_faces, radius):
    """The body's radius (one per body vertex) at each point's nearest body point, blended over
    its triangle's corners."""
    return np.einsum("ij,ij->i", corr.bary, radius[body_faces[corr.triangle]])


@dataclass(frozen=True)
class ProbeReach:
    """What a resolve's probes may reach: ``per_segment`` l_s per part id; ``radius`` the body's
    radius per body vertex when some part keeps its default (None otherwise); ``local`` when
    there are no parts and each garment vertex takes the radius at its nearest body point;
    ``junctions`` where a part meets another (part_junctions), which probes near them also reach."""

    per_segment: np.ndarray
    radius: np.ndarray | None
    local: bool
    junctions: tuple


def probe_reach(body, params) -> ProbeReach:
    """The resolve's ProbeReach on the BodyFacts ``body`` for its LayeringParameters ``params``."""
    given = params.probe_given
    radius = body.radius if given is None or np.isnan(given).any() else None
    per_segment = given if radius is None else body.probe_lengths(params.body_segments, params.n_segments,
                                                                   params.links, given)
    # Without segments (one part) the probe distance follows the body locally: each garment
    # vertex takes the body's radius at its nearest point, so a sleeve probe stops inside the arm.
    local = given is None and not params.parts_given
    junctions = (body.junctions(params.body_segments)
                 if params.segment_margin > 0 and len(np.unique(params.body_segments)) > 1 and not params.one_part
                 else (np.zeros((0, 3)), np.zeros(0, np.int64), np.zeros(0, np.int64)))
    return ProbeReach(per_segment, radius, local, junctions)


# A part's default reach widens to where its lower layers' cloth hangs, at most this many times over.
WIDEST = 4.0


def widened(reach: ProbeReach, prep, params, gap: float) -> ProbeReach:
    """``reach`` with each part that keeps its default widened to its lower layers' farthest point
    from the body, plus the gap: the default (the part's median radius) is the body's measure,
    and loose cloth round a thin limb hangs farther (Fig. 4.12's sleeves: up to 44 mm from arms
    whose radius is 10.5 mm; unprobed, 600 of their points crossed and were hidden: poke-through
    0.038% -> 0.006%, at the 99th percentile 0.014% and 28 points). At most WIDEST times the
    default (a stray point far off does not send every probe across the body). The per-vertex
    reach of ``prep`` (a GarmentPrep) and its count of points beyond it follow. Unchanged
    without parts."""
    if reach.local or params.one_part or len(prep.active) < 2:
        return reach
    lower = prep.active[:-1]  # the outermost layer sends no probe
    dist = np.concatenate([prep.corr[i].distance for i in lower])
    part = np.concatenate([prep.vseg[i] for i in lower])
    per = widen(reach.per_segment, dist, part, params.probe_given, gap)
    if np.array_equal(per, reach.per_segment):
        return reach
    for i in prep.active:
        prep.probe_len[i] = np.maximum(prep.probe_len[i], per[prep.vseg[i]])
    prep.far = sum(int((prep.corr[i].distance > prep.probe_len[i]).sum()) for i in prep.active)
    return ProbeReach(per, reach.radius, reach.local, reach.junctions)


def widen(per_segment, distance, part, given, gap) -> np.ndarray:
    """``per_segment`` (l_s per part id) with each part that keeps its default (NaN in ``given``, or
    no ``given``) widened to the farthest ``distance`` from the body of the lower layers' points
    of that part (``part`` per point) plus ``gap``, at most WIDEST times the default: the one rule
    the resolve (``widened``) and the render engine (``body_probes``) take."""
    per = np.array(per_segment, dtype=np.float64, copy=True)
    for s in np.unique(part):
        if given is not None and not np.isnan(given[s]):
            continue
        need = float(distance[part == s].max()) + gap
        per[s] = min(max(per[s], need), WIDEST * per[s])
    return per


class BodyParts(NamedTuple):
    """The body's part of each of its vertices, and the segmentation scheme they follow (None:
    parts numbered by the caller, no scheme)."""

    ids: np.ndarray
    scheme: str | None = None


def body_probes(objects, layers, given=None, parts: BodyParts | None = None, traced=None, gap=None):
    """l_s per vertex as the resolve takes it: ``given`` (one distance, or one per part with
    NaN where the part keeps its default) or else the body's radius (half its thickness
    straight through), each part's median when the body has ``parts`` and the radius under
    each vertex when it has none; every vertex of the body and the garments takes the value
    of the part of its nearest body vertex. With the scheme the parts follow, a garment whose
    hem goes round both legs (a skirt) takes the skirt segment's l_s on the legs, as in the
    resolve (BodyFacts.probe_lengths: its linked parts' farthest reach, or its override).
    Objects outside the layering, or all of them when there is no body, keep the default
    (None), as do those whose ``traced`` (one bool per object) is False: the outermost layer,
    which nothing is worn over, sends no probe. With parts, each part keeping its default
    widens as the resolve's does (``widen``: to its lower layers' farthest point plus ``gap``,
    default the resolve's default offset)."""
    if given is not None and np.ndim(given) == 0:
        return float(given)
    if given is not None and parts is None:
        raise ValueError("probe distances per part need the body's parts")
    body = next((i for i, lay in enumerate(layers) if lay == 0), None)
    if body is None:
        return None
    facts = body_facts(*objects[body])  # kept: the next frame of a still body asks again
    traced = [True] * len(objects) if traced is None else traced
    scheme = None if parts is None or parts.scheme is None else get_scheme(parts.scheme)
    parts = None if parts is None else np.asarray(parts.ids, np.int64)
    # a body vertex is its own nearest point, on the part its groups give it
    found = [None if lay is None or not go else None if i == body else nearest_part(facts, v, f, parts, scheme)
             for i, ((v, f), lay, go) in enumerate(zip(objects, layers, traced, strict=True))]
    own = traced[body] and layers[body] is not None
    if parts is None:
        return [(facts.radius if own else None) if i == body else None if hit is None else hit.radius
                for i, hit in enumerate(found)]
    if scheme is not None:
        count, links = len(scheme.parts), scheme.links()
    else:
        count = max(int(parts.max(initial=-1)) + 1, 0 if given is None else len(given))
        links = np.eye(count, dtype=bool)
    per_part = facts.probe_lengths(parts, count, links, given)
    part_of = [(parts if own else None) if i == body else None if hit is None else hit.part
               for i, hit in enumerate(found)]
    # as the resolve: only cloth worn under another garment widens its part's reach
    top = max((lay for lay in layers if lay is not None), default=0)
    lower = [i for i, hit in enumerate(found) if hit is not None and 0 < layers[i] < top]
    if lower:
        gap = OFFSET_SHARE * body_size(facts) if gap is None or gap <= 0 else float(gap)
        per_part = widen(per_part, np.concatenate([found[i].distance for i in lower]),
                         np.concatenate([part_of[i] for i in lower]), given, gap)
    return [None if p is None else per_part[p] for p in part_of]


@dataclass(frozen=True)
class NearestOnBody:
    """What the engine reads of an object's points at their nearest body points."""

    part: np.ndarray | None  # body part per point (skirt segments for a skirt), None without parts
    radius: np.ndarray  # the body's radius there
    distance: np.ndarray  # to the body


def nearest_part(facts, vertices, faces, parts, scheme) -> NearestOnBody:
    """Each point's part, radius and distance at its nearest body surface point (``part_at``,
    ``radius_at``), a skirt's points on the legs taking its segments as in the resolve; kept by
    content, so the next frame of an object that has not moved (a render after a light's tweak,
    a still garment in an animation) finds it again instead of searching."""
    key = (digest(vertices, faces, *(() if parts is None else (parts,))), repr(scheme))
    kept = facts.nearest_kept.get(key)
    if kept is not None:
        return kept
    corr = nearest_on_surface(vertices, facts.vertices, facts.faces, search=facts.search)
    part = None
    if parts is not None:
        part, _ = part_at(corr, facts.faces, parts)
        if scheme is not None and len(faces) and is_skirt(faces, part, scheme, vertices=vertices,
                                                          body=(facts.vertices, parts)):
            part = skirt_segments(part, scheme)
    found = NearestOnBody(None if part is None else frozen(part), frozen(radius_at(corr, facts.faces, facts.radius)),
                          frozen(corr.distance))
    facts.nearest_kept.put(key, found)
    return found
