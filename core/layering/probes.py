"""How far probe rays look (l_s, thesis Fig. 4.5) and which body part's triangles they meet: one
rule for the resolve (``probe_reach``, ``widened``) and for the DeformRT Layered render engine
(``body_probes``), both widening a part's reach where loose cloth hangs (``widen``). Both take
each part's l_s from BodyFacts.probe_lengths (the part's median radius, a skirt's its linked
parts' farthest, overrides per part) or, without parts, the body's radius under each point. The
resolve reads a garment vertex's part at its nearest body surface point (found once per garment
and kept); the engine, for every object of every frame, at its nearest body vertex (a k-d tree
query), the same part but at part borders, where a probe meets both parts' triangles anyway
(the segment margin)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry.keys import digest
from ..geometry.vectors import norms, rows, size_of
from .body_facts import body_facts, frozen
from .parameters import OFFSET_SHARE
from .segmentation import get_scheme, is_skirt, skirt_segments


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


def body_probes(objects, layers, given=None, parts=None, scheme=None, traced=None, gap=None):
    """l_s per vertex as the resolve takes it: ``given`` (one distance, or one per part with
    NaN where the part keeps its default) or else the body's radius (half its thickness
    straight through), each part's median when the body has ``parts`` (one id per body vertex)
    and the radius under each vertex when it has none; every vertex of the body and the
    garments takes the value of the part of its nearest body vertex. With the ``scheme`` the
    parts follow, a garment whose hem goes round both legs (a skirt) takes the skirt
    segment's l_s on the legs, as in the resolve (BodyFacts.probe_lengths: its linked parts'
    farthest reach, or its override). Objects outside the layering, or all of them when there
    is no body, keep the default (None), as do those whose ``traced`` (one bool per object) is
    False: the outermost layer, which nothing is worn over, sends no probe. With parts, each part
    keeping its default widens as the resolve's does (``widen``: to its lower layers' farthest
    point plus ``gap``, default the resolve's default offset), the distance taken to the nearest
    body vertex (at most an edge farther than the nearest surface point the resolve measures)."""
    if given is not None and np.ndim(given) == 0:
        return float(given)
    if given is not None and parts is None:
        raise ValueError("probe distances per part need the body's parts")
    body = next((i for i, lay in enumerate(layers) if lay == 0), None)
    if body is None:
        return None
    facts = body_facts(*objects[body])  # kept: the next frame of a still body asks again
    traced = [True] * len(objects) if traced is None else traced
    parts = None if parts is None else np.asarray(parts, np.int64)
    scheme = None if scheme is None else get_scheme(scheme)
    # a body vertex is its own nearest (a triangle's vertex sits in the tree at distance 0)
    nearest = [None if lay is None or not go else (np.arange(len(v)), False) if i == body
               else nearest_part(facts, v, f, parts, scheme)
               for i, ((v, f), lay, go) in enumerate(zip(objects, layers, traced, strict=True))]
    if parts is None:
        return [None if found is None else facts.radius[found[0]] for found in nearest]
    if scheme is not None:
        count, links = len(scheme.parts), scheme.links()
    else:
        count = max(int(parts.max(initial=-1)) + 1, 0 if given is None else len(given))
        links = np.eye(count, dtype=bool)
    per_part = facts.probe_lengths(parts, count, links, given)
    part_of = [None if found is None else skirt_segments(parts[found[0]], scheme) if found[1] else parts[found[0]]
               for found in nearest]
    # as the resolve: only cloth worn under another garment widens its part's reach
    top = max((lay for lay in layers if lay is not None), default=0)
    lower = [i for i, found in enumerate(nearest) if found is not None and i != body and 0 < layers[i] < top]
    if lower:
        gap = OFFSET_SHARE * size_of(facts.vertices) if gap is None or gap <= 0 else float(gap)
        distance = np.concatenate([norms(objects[i][0] - rows(facts.vertices, nearest[i][0])) for i in lower])
        per_part = widen(per_part, distance, np.concatenate([part_of[i] for i in lower]), given, gap)
    return [None if p is None else per_part[p] for p in part_of]


def nearest_part(facts, vertices, faces, parts, scheme):
    """(each garment vertex's nearest body vertex, whether the garment is a skirt under the
    ``scheme`` the body's ``parts`` follow), kept with the body's facts: the next frame of a
    garment that has not moved (a render after a light's tweak, a still garment in an
    animation) finds it again instead of searching (30-40 ms a frame on Fig 4.13)."""
    key = b"render nearest" + digest(vertices, faces, *(() if parts is None else (parts,))) + repr(scheme).encode()
    found = facts.prepared(key)
    if found is not None:
        return found
    search = facts.search
    at = search.vertex_ids[search.tree.query(vertices, workers=-1)[1]]
    skirt = bool(parts is not None and scheme is not None and len(faces)
                 and is_skirt(faces, parts[at], scheme, vertices=vertices, body_vertices=facts.vertices,
                              body_segments=parts))
    found = (frozen(at), skirt)
    facts.keep_prepared(key, found)
    return found
