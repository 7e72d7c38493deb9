"""What a resolve needs to know about the body alone, kept across calls for the same body (by
content): an artist resolving again after a tweak, or cloth frame after frame on a still stage,
pays for the body's normals, radii, nearest-point search and part junctions once."""

from __future__ import annotations

import numpy as np
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from ..geometry.cache import Cache, nbytes
from ..geometry.keys import digest
from ..geometry.normals import vertex_normals_and_area
from ..geometry.parallel import tree_workers
from ..geometry.topology import faces_key, topology_of, vertex_adjacency
from ..geometry.vectors import box, norms, rows
from ..rays.scene import FEW_RAYS, RayScene
from ..rays.scene_cache import forget_scenes
from .correspondence import closest_point_on_triangles, incident_triangles, local_radius, surface_search, vertex_tree

# the last few bodies' facts, by content
BODIES = Cache(max_entries=4)
# garments' pre-processing kept per body: a figure's four garments a few times over, within a
# memory budget (about 120 bytes a garment vertex); a body made after a change takes the new one
KEEP_PREPARED = 16
PREPARED_BYTES = 256 * 2**20


def frozen(a):
    a = np.array(a, copy=True)
    a.flags.writeable = False
    return a


class BodyFacts:
    """Lazily computed facts about one body mesh (vertices, faces)."""

    def __init__(self, vertices, faces, faces_key=None):
        # own read-only copies: what is kept must not change under the key it is kept by
        self.vertices, self.faces = frozen(vertices), frozen(faces)
        self._faces_key = faces_key  # topology.faces_key(faces), when known
        self._normals = self._radius = self._search = self._pieces = self._scene = self._edges = None
        self._area = 0.0
        self._normal_agreement = self._tree = self._ends = None
        self._longest = None
        self._topology = None
        self._carried_junctions = {}
        self._junctions = {}
        self.prepared_kept = Cache(max_entries=KEEP_PREPARED, max_bytes=PREPARED_BYTES)
        # the render engine's, apart: each object's nearest points on this body (probes.nearest_part)
        self.nearest_kept = Cache(max_entries=KEEP_PREPARED)

    @property
    def normals(self) -> np.ndarray:
        if self._normals is None:
            normals, self._area = vertex_normals_and_area(self.vertices, self.faces)
            self._normals = frozen(normals)
        return self._normals

    @property
    def area(self) -> float:
        """The skin's area: the triangles' total (found with the normals)."""
        if self._normals is None:
            _ = self.normals
        return self._area

    @property
    def radius(self) -> np.ndarray:
        """Half the chord through the body from each vertex (correspondence.local_radius)."""
        if self._radius is None:
            self._radius = frozen(local_radius(self.vertices, self.faces, self.normals, scene=self.scene))
        return self._radius

    @property
    def scene(self) -> RayScene:
        """The body's ray scene."""
        if self._scene is None:
            self._scene = RayScene(self.vertices, self.faces, quality=FEW_RAYS)
        return self._scene

    @property
    def edges(self):
        """The body's edges: (sorted vertex pairs, lows, highs), the boxes column by column."""
        if self._edges is None:
            e, (a, b) = self.topology.edges, self._edge_ends
            self._edges = (e, [np.minimum(a[:, i], b[:, i]) for i in range(3)],
                           [np.maximum(a[:, i], b[:, i]) for i in range(3)])
        return self._edges

    @property
    def _edge_ends(self):
        """The two end points of each of the body's edges (topology.edges), gathered once a frame
        for both the edges' boxes and the longest edge."""
        if self._ends is None:
            e = self.topology.edges
            self._ends = (rows(self.vertices, e[:, 0]), rows(self.vertices, e[:, 1]))
        return self._ends

    @property
    def topology(self):
        """The body's MeshTopology (its faces hashed once for this body, not at every ask)."""
        if self._topology is None:
            self._topology = topology_of(self.faces, len(self.vertices), key=self._faces_key)
        return self._topology

    @property
    def vertex_faces(self):
        """MeshTopology.vertex_faces of the body (kept with its topology)."""
        return self.topology.vertex_faces

    @property
    def longest_edge(self) -> float:
        if self._longest is None:
            a, b = self._edge_ends
            self._longest = float(norms(a - b).max(initial=0.0))
        return self._longest

    @property
    def vertex_tree(self):
        """correspondence.vertex_tree of the body, for nearest_within (one a frame for every garment)."""
        if self._tree is None:
            self._tree = vertex_tree(self.vertices)
        return self._tree

    @property
    def search(self):
        """correspondence.surface_search of the body, for nearest_on_surface."""
        if self._search is None:
            self._search = surface_search(self.vertices, self.faces, 8)
        return self._search

    @property
    def normal_agreement(self) -> np.ndarray:
        """Per triangle, the least dot product between two of its corners' normals: a blend of
        them by barycentric weights is at least its square root long (0 where they part by 90
        degrees or more, or a corner has no normal)."""
        if self._normal_agreement is None:
            a, b, c = (self.normals[self.faces[:, k]] for k in range(3))
            dots = [np.einsum("ij,ij->i", x, y) for x, y in ((a, b), (b, c), (a, c))]
            self._normal_agreement = frozen(np.minimum(np.minimum(dots[0], dots[1]), dots[2]))
        return self._normal_agreement

    @property
    def pieces(self) -> np.ndarray:
        """Per vertex, which connected piece of the body mesh it is on (0..pieces-1)."""
        if self._pieces is None:  # the topology's alone: kept with it for the next frame's body
            topo = self.topology
            if topo.pieces is None:
                adjacency = vertex_adjacency(self.faces, len(self.vertices), edges=topo.edges)
                topo.pieces = frozen(connected_components(adjacency, directed=False)[1].astype(np.int64))
            self._pieces = topo.pieces
        return self._pieces

    @property
    def radius_found(self):
        """The radii if a resolve has asked for them (else None: nothing is traced for this)."""
        return self._radius

    def carry_radius(self, radius) -> None:
        """Take the last frame's radii for this body of the same topology (posed or skinned: a
        limb's chord hardly changes), instead of tracing the body again; kept probe lengths also
        keep the probes from changing frame to frame."""
        if self._radius is None and radius is not None and len(radius) == len(self.vertices):
            self._radius = frozen(radius)

    def part_radius(self, segment, count: int) -> np.ndarray:
        """Each part's median radius (the thesis' l_s per part), for ids 0..count-1 of one
        segment id per vertex; NaN for a part with no vertex of its own (the skirt)."""
        segment = np.asarray(segment)
        return np.array([np.median(self.radius[segment == s]) if (segment == s).any() else np.nan
                         for s in range(count)])

    def probe_lengths(self, segment, count: int, links, given=None) -> np.ndarray:
        """l_s per segment id 0..count-1, one rule for the resolve and the render engine: each
        part's median radius; a segment with no body vertex of its own (the skirt) reaches as
        far as the farthest part it is linked to (``links``, (count, count) bool), or the
        body's median radius if none has vertices; then ``given`` (per id, NaN keeps the
        default) replaces the defaults."""
        out = self.part_radius(segment, count)
        for s in np.flatnonzero(np.isnan(out)):
            linked = out[np.asarray(links)[s]]
            out[s] = np.nanmax(linked) if np.isfinite(linked).any() else np.median(self.radius)
        return out if given is None else np.where(np.isnan(given), out, given)

    def junctions(self, segment):
        """``part_junctions`` of this body under ``segment``, kept for the next call."""
        return self._junctions_of(segment)[0]

    def junction_distance(self, segment, at):
        """For body vertices ``at``, the distance to the nearest junction of their own part (inf:
        their part has none): with the triangle inequality, a lower bound on any point's distance
        to them. Found for the vertices asked only (a garment's nearest body corners: a third of
        a figure's), each kept for the next ask."""
        found = self._junctions_of(segment)
        if found[1] is None:
            found[1] = np.full(len(self.vertices), np.nan)
        out = found[1]
        unknown = np.unique(at[np.isnan(out[at])])
        if len(unknown):
            pos, own, _ = found[0]
            parts = segment[unknown]
            for part in np.unique(parts):
                mine = unknown[parts == part]
                ends = pos[own == part]
                out[mine] = cKDTree(ends).query(rows(self.vertices, mine))[0] if len(ends) else np.inf
        return out[at]

    def _junctions_of(self, segment):
        key = digest(segment)
        if key not in self._junctions:
            at, other = self._carried_junctions.get(key) or junction_vertices(self.vertices, self.faces, segment)
            self._junctions = {key: [(self.vertices[at], segment[at], other), None, (at, other)]}
        return self._junctions[key]

    def junctions_found(self):
        """{segment digest: (junction vertices, other part)} a resolve asked for, for the next frame."""
        return {k: v[2] for k, v in self._junctions.items()}

    def carry_junctions(self, found) -> None:
        """Take the last frame's junction vertices for this body of the same topology and parts (where
        parts meet moves with the body; which vertices lie there hardly changes)."""
        if found:
            self._carried_junctions = dict(found)

    def prepared(self, key):
        """What a resolve on this body found for one garment (its body points, normals, parts),
        kept under ``key`` (the digest of everything it was found from), or None."""
        return self.prepared_kept.get(key)

    def keep_prepared(self, key, entry) -> None:
        """Keep ``entry`` (a tuple of arrays, BodyCorrespondences and numbers), the least recent
        going first past the count or the memory budget (an entry over the budget is not kept)."""
        self.prepared_kept.put(key, entry, nbytes(entry))


def body_facts(vertices, faces) -> BodyFacts:
    """The BodyFacts of this body, the same object for the same content (the last few bodies)."""
    # the faces hashed once a frame, for this key and the topology's (a body's faces outweigh its vertices 2:1)
    fk = faces_key(faces)
    key = digest(vertices, np.frombuffer(fk, np.uint8))
    found = BODIES.get(key)
    if found is None:
        found = BodyFacts(vertices, faces, fk)
        BODIES.put(key, found)
    return found


def forget_garments() -> None:
    """Drop what was kept of every garment (the bodies' own facts stay), their ray scenes too:
    resolving garments after it costs what newly draped garments on a known body cost."""
    for facts in BODIES.values():
        facts.prepared_kept.clear()
        facts.nearest_kept.clear()
    forget_scenes()


def part_junctions(vertices, faces, segment):
    """Body vertices where two parts meet: an edge to a vertex of another part (one surface),
    or within half an edge of another part's surface (parts modelled apart that overlap at
    the joints). Returns (positions, own part, other part)."""
    at, other = junction_vertices(vertices, faces, segment)
    return vertices[at], segment[at], other


def junction_vertices(vertices, faces, segment):
    """part_junctions' vertices and the other part at each: (indices, other part)."""
    e = topology_of(faces, len(vertices)).edges  # the body's, kept for the next call
    cross = segment[e[:, 0]] != segment[e[:, 1]]
    at = [e[cross, 0], e[cross, 1]]
    other = [segment[e[cross, 1]], segment[e[cross, 0]]]
    lengths = norms(rows(vertices, e[:, 0]) - rows(vertices, e[:, 1]))
    reach = 0.5 * float(lengths.mean()) if len(lengths) else 0.0
    # another part's surface that close has a vertex within an edge: its nearest vertex of
    # another part, from a tree per part (points outside a part's box plus that reach skip it)
    bound = float(lengths.max(initial=0.0)) + reach
    best_d, best_j = np.full(len(vertices), np.inf), np.full(len(vertices), -1)
    members = {p: np.flatnonzero(segment == p) for p in np.unique(segment)}
    for q, theirs in members.items():
        their_points = rows(vertices, theirs)
        tree, (lo, hi) = cKDTree(their_points), box(their_points)
        for p, mine in members.items():
            if p == q:
                continue
            inside = np.ones(len(mine), dtype=bool)
            for k in range(3):
                inside &= (vertices[mine, k] >= lo[k] - bound) & (vertices[mine, k] <= hi[k] + bound)
            mine = mine[inside]
            if len(mine):
                d, j = tree.query(rows(vertices, mine), distance_upper_bound=bound, workers=tree_workers(len(mine)))
                better = d < best_d[mine]
                best_d[mine[better]], best_j[mine[better]] = d[better], theirs[j[better]]
    row = np.flatnonzero(np.isfinite(best_d))
    if len(row):
        nb = best_j[row]
        tris = incident_triangles(faces, len(vertices), 8)[nb]  # (pairs, 8), -1 padded
        pr, pc = np.nonzero(tris >= 0)
        tri_id = tris[pr, pc]
        # only the neighbour's own part's triangles
        ok = (segment[faces[tri_id]] == segment[nb[pr]][:, None]).all(1)
        pr, tri_id = pr[ok], tri_id[ok]
        p = vertices[row[pr]]
        abc = rows(vertices, rows(faces, tri_id))
        w = closest_point_on_triangles(p, abc[:, 0], abc[:, 1], abc[:, 2])
        dist = np.linalg.norm(p - np.einsum("ij,ijk->ik", w, abc), axis=1)
        close = dist <= reach
        at.append(row[pr[close]])
        other.append(segment[nb[pr[close]]])
    at, other = np.concatenate(at), np.concatenate(other)
    key = np.unique(at * (int(segment.max()) + 1) + other)
    return key // (int(segment.max()) + 1), key % (int(segment.max()) + 1)
