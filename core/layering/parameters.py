"""A resolve's inputs and parameters, read and checked once at the boundary, with a message that
names what is wrong (resolve_layers' docstring says what each parameter means)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import trimesh

from ..geometry.vectors import box, cross, rows, size_of
from .segmentation import Scheme, get_scheme

KNOWN = frozenset({"offset", "probe_distance", "garment_segments", "global_normals", "boundary_pass", "push_behind",
                   "body_guard", "outer_room", "remove_hidden", "falloff", "scheme", "segment_links", "correspondence",
                   "segment_margin", "outward_shells", "simulated", "subdivided"})


MAX_OFFSET = 0.05  # of the body's size
MAX_SEGMENTS = 4096


def check_known(params) -> None:
    unknown = set(params) - KNOWN
    if unknown:
        raise ValueError(f"unknown parameter(s) {sorted(unknown)}; known: {sorted(KNOWN)}")


def mesh_arrays(mesh, name):
    """(vertices float64 (n, 3), faces int64 (m, 3)) of a mesh, checked."""
    if mesh is None:
        raise ValueError(f"{name} is missing")
    if not hasattr(mesh, "vertices") or not hasattr(mesh, "faces"):
        raise ValueError(f"{name} must be a trimesh.Trimesh (or have .vertices and .faces), got {type(mesh).__name__}")
    v = np.asarray(mesh.vertices, dtype=np.float64).reshape(-1, 3)
    f = np.asarray(mesh.faces, dtype=np.int64).reshape(-1, 3)
    if not np.isfinite(v).all():
        raise ValueError(f"{name} has NaN or infinite vertex coordinates")
    if len(f) and (f.min() < 0 or f.max() >= len(v)):
        raise ValueError(f"{name} has faces that refer to vertices outside 0..{len(v) - 1}")
    return v, f


def read_meshes(body, garments):
    """The body's and each garment's arrays, checked: (body vertices, body faces, [(v, f), ...])."""
    body_vertices, body_faces = mesh_arrays(body, "body")
    if not len(body_faces):
        raise ValueError("body has no faces: the garments need a body surface to take normals from")
    if garments is None or isinstance(garments, trimesh.Trimesh):
        raise ValueError("garments must be a list of meshes, inner to outer")
    return body_vertices, body_faces, [mesh_arrays(g, f"garments[{i}]") for i, g in enumerate(garments)]


def inside_out(vertices, faces) -> bool:
    """Whether a body's faces wind inward (flipped winding, or a mirrored object): its signed
    volume is negative and large enough to mean it (a twentieth of its box's; an open sheet of a
    body has next to none and is left as it is). Its normals would point into it, and every
    garment point would take the far side of the body as its own."""
    a, b, c = (rows(vertices, faces[:, k]) for k in range(3))
    signed = float((a * cross(b, c)).sum()) / 6.0  # one sum over every face: no dot per face needed
    lo, hi = box(vertices)
    return signed < -0.05 * float(np.prod(np.maximum(hi - lo, 1e-300)))


def _per_garment(value, n, name):
    if value is None:
        return [None] * n
    if len(value) != n:
        raise ValueError(f"{name} needs one entry per garment ({n}), got {len(value)}")
    return list(value)


def _shell_gap(shells, n_garments) -> float:
    """What the gap between layers must add for the outward shells given (see resolve_layers)."""
    if shells is None:
        return 0.0
    shells = np.asarray(shells, dtype=np.float64)
    if shells.shape != (n_garments,) or not np.isfinite(shells).all() or (shells < 0).any():
        raise ValueError(f"outward_shells must be {n_garments} finite thicknesses >= 0, got {shells.tolist()}")
    return float(shells[:-1].max(initial=0.0))



# The offset d when none is asked, as a share of the body's size (about 2 mm on a person)
OFFSET_SHARE = 1e-3
# A standing figure's box in its own axes has a diagonal 1.57-1.59 times the square root of its
# skin's area (MakeHuman's female and male bodies); posed, the box swings from 0.82 to 1.17 times
# its standing size (hugging the knees, a T-pose) while the square root of the skin's area changes
# by at most 2%
STANDING_SIZE_PER_SKIN = 1.6


def body_size(body) -> float:
    """The size of a BodyFacts' body the defaults are taken from: the diagonal of its box in its
    own axes (vectors.size_of: turning the scene does not change it), at most what a standing
    figure of its skin's area spans (STANDING_SIZE_PER_SKIN). The gap between layers, and the
    easing's bounds measured in it, do not grow when a figure spreads its arms or legs: with the
    box alone, the correction's largest jolt a frame followed the pose (on MakeHuman's male figure,
    from 3.8 mm in a lunge to 4.7 mm jogging or bending sideways with an arm up). A compact body
    (a ball, a box, a sheet: its skin would span 1.1 to 2.2 times its box) keeps its box's size."""
    size = size_of(body.vertices)
    skin = body.area
    return min(size, STANDING_SIZE_PER_SKIN * float(np.sqrt(skin))) if skin > 0 else size


@dataclass(frozen=True)
class LayeringParameters:
    """Everything a resolve was asked, checked, in the units of the scene."""

    offset: float  # d: the gap a lower layer keeps behind a higher one, and from the body
    gap: float  # d plus the thickest outward shell of a lower layer: what push and tuck leave
    body_segments: np.ndarray  # part id per body vertex
    parts_given: bool  # the caller gave the parts (else: the body's connected pieces)
    scheme: Scheme | None
    n_segments: int
    links: np.ndarray  # (S, S) which parts' triangles each part's rays meet
    one_part: bool  # every part meets every other: traced as one
    probe_given: np.ndarray | None  # l_s per part asked for, NaN: the part's default; None: all default
    segment_margin: float
    diagonal: float  # the body's size the defaults come from (body_size)
    garment_segments: list
    global_normals: list
    correspondence: list
    boundary_pass: bool
    push_behind: bool
    body_guard: bool
    outer_room: bool
    remove_hidden: bool
    falloff: float | None
    simulated: list  # per garment: its cloth is simulated (resolve._guarded, frame_coherence.held_hidden)
    subdivided: list  # per garment: a Subdivision Surface smooths it after the correction (outer_room)

    @classmethod
    def parse(cls, body, body_vertices, body_faces, garment_arrays, body_segments, params) -> LayeringParameters:
        """From resolve_layers' arguments, on the BodyFacts ``body`` of (body_vertices, body_faces)."""
        n_g = len(garment_arrays)
        body_seg = _body_parts(body, body_vertices, body_segments)
        g_segments = _per_garment(params.get("garment_segments"), n_g, "garment_segments")
        g_normals = _per_garment(params.get("global_normals"), n_g, "global_normals")
        g_corr = _per_garment(params.get("correspondence"), n_g, "correspondence")
        scheme, n_seg = _scheme_of(params.get("scheme"), body_seg, body_segments is not None)
        links = _links(params.get("segment_links"), scheme, n_seg)
        diag, d, gap = _gaps(body, params, n_g)
        given = _probe_given(params.get("probe_distance"), n_seg, diag)
        margin = float(params.get("segment_margin", 0.01 * diag))
        if not np.isfinite(margin) or margin < 0:
            raise ValueError(f"segment_margin must be a finite distance >= 0, got {margin}")
        falloff = params.get("falloff")
        if falloff is not None and not (np.isfinite(falloff) and falloff > 0):
            raise ValueError(f"falloff must be a finite distance > 0 (or None for four edge lengths), got {falloff}")
        _check_garment_inputs(garment_arrays, len(body_faces), n_seg, (g_corr, g_normals, g_segments))
        return cls(offset=d, gap=gap, body_segments=body_seg, parts_given=body_segments is not None, scheme=scheme,
                   n_segments=n_seg, links=links, one_part=scheme is None and bool(links.all()), probe_given=given,
                   segment_margin=margin, diagonal=diag, garment_segments=g_segments, global_normals=g_normals,
                   correspondence=g_corr, boundary_pass=bool(params.get("boundary_pass", True)),
                   push_behind=bool(params.get("push_behind", True)), body_guard=bool(params.get("body_guard", True)),
                   outer_room=bool(params.get("outer_room", True)),
                   remove_hidden=bool(params.get("remove_hidden", True)),
                   falloff=None if falloff is None else float(falloff),
                   simulated=[bool(s) for s in _per_garment(params.get("simulated"), n_g, "simulated")],
                   subdivided=[bool(s) for s in _per_garment(params.get("subdivided"), n_g, "subdivided")])


def _body_parts(body, body_vertices, body_segments):
    """The body's part id per vertex: as given, or its separate pieces (a figure modelled as parts)."""
    if body_segments is None:
        return body.pieces
    body_seg = np.asarray(body_segments)
    if body_seg.shape != (len(body_vertices),) or not np.issubdtype(body_seg.dtype, np.integer) or (body_seg < 0).any():
        raise ValueError(f"body_segments must be {len(body_vertices)} non-negative integers, one per body vertex")
    return body_seg.astype(np.int64)


def _scheme_of(scheme, body_seg, parts_given):
    """(the segmentation scheme named, or None; how many parts there are)."""
    n_seg = int(body_seg.max()) + 1
    if n_seg > MAX_SEGMENTS:  # the part-to-part links are a square table of them
        raise ValueError(f"body_segments ids go up to {n_seg - 1}: number the body's parts 0..k-1 "
                         f"(at most {MAX_SEGMENTS} parts)")
    if scheme is None:
        return None, n_seg
    if not parts_given:
        raise ValueError("a segmentation scheme names body part ids: pass body_segments with it")
    scheme = get_scheme(scheme)
    if n_seg > scheme.skirt:
        raise ValueError(f"body_segments of scheme {scheme.name} must be ids 0..{scheme.skirt - 1} "
                         f"({', '.join(scheme.parts[:-1])}); got up to {n_seg - 1}")
    return scheme, len(scheme.parts)


def _links(links, scheme, n_seg):
    """Which parts' rays may meet which parts' triangles: symmetric, each part its own."""
    if links is None:
        return scheme.links() if scheme is not None else np.eye(n_seg, dtype=bool)
    links = np.asarray(links, dtype=bool)
    if links.ndim == 0:  # True: every part meets every other (a whole body of separate pieces)
        links = np.full((n_seg, n_seg), bool(links))
    if links.shape != (n_seg, n_seg):
        raise ValueError(f"segment_links must be ({n_seg}, {n_seg}) booleans, got shape {links.shape}")
    return links | links.T | np.eye(n_seg, dtype=bool)


def _gaps(body, params, n_g):
    """(the body's size, the offset between layers, the gap with the outward shells)."""
    diag = body_size(body)
    if diag <= 0:
        raise ValueError("body has zero size")
    d = float(params.get("offset", OFFSET_SHARE * diag))
    if not np.isfinite(d) or d < 0:
        raise ValueError(f"offset must be a finite distance >= 0, got {d}")
    if d > MAX_OFFSET * diag:  # a gap wider than a limb: a typo or a unit mix-up, never a layer
        raise ValueError(f"offset {d:g} is more than {MAX_OFFSET:.0%} of the body's size ({diag:g}): "
                         "give the gap between layers in the scene's units (about 0.1% of the body)")
    return diag, d, d + _shell_gap(params.get("outward_shells"), n_g)


def _probe_given(probe, n_seg, diag):
    """The probe distance per part as given (NaN: the part's default), or None."""
    given = None if probe is None else np.broadcast_to(np.asarray(probe, dtype=np.float64), (n_seg,)).copy()
    if given is not None and (np.isinf(given).any() or (given < 0).any()):
        raise ValueError("probe_distance must be finite and >= 0 (NaN for a part's default)")
    if given is not None and np.nanmax(given, initial=0.0) > diag:
        raise ValueError(f"probe_distance {np.nanmax(given):g} is longer than the body ({diag:g}): "
                         "give about a body part's radius in the scene's units")
    if given is not None and np.isnan(given).all():
        return None
    return given


def _check_garment_inputs(garment_arrays, n_body_faces, n_seg, per_garment):
    """Every given per-garment input fits its garment (checked now: the untraced are prepared later)."""
    g_corr, g_normals, g_segments = per_garment
    for i, (v, _) in enumerate(garment_arrays):
        c = g_corr[i]
        if c is not None and (len(c.triangle) != len(v) or (len(c.triangle) and c.triangle.max() >= n_body_faces)):
            raise ValueError(f"correspondence[{i}] is for another mesh: {len(c.triangle)} points for "
                             f"{len(v)} vertices, or triangles beyond the body's {n_body_faces}")
        n = g_normals[i]
        if n is not None and (np.shape(n) != v.shape or not np.isfinite(n).all()):
            raise ValueError(f"global_normals[{i}] must be finite with shape {v.shape}")
        s = g_segments[i]
        if s is not None and (np.shape(s) != (len(v),) or (len(s) and (np.min(s) < 0 or np.max(s) >= n_seg))):
            raise ValueError(f"garment_segments[{i}] must be {len(v)} ids in 0..{n_seg - 1}")
