"""Topological queries on triangle meshes: boundary points (Fig. 4.8), neighbours and distances
over the surface (Fig. 4.9)."""

from __future__ import annotations

import numpy as np
from scipy import sparse
from scipy.sparse import csgraph

from .cache import Cache
from .keys import digest
from .normals import face_normals


def edges_with_counts(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unique undirected edges (sorted pairs, in lexicographic order) and how many triangles use each."""
    f = np.asarray(faces, dtype=np.int64)
    if not len(f):
        return np.zeros((0, 2), np.int64), np.zeros(0, np.int64)
    a = np.concatenate([f[:, 0], f[:, 1], f[:, 2]])
    b = np.concatenate([f[:, 1], f[:, 2], f[:, 0]])
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    keep = lo != hi
    # One int64 key per edge: a 1-D unique is an order of magnitude faster than unique(axis=0).
    stride = np.int64(hi.max() + 1) if len(hi) else np.int64(1)
    keys, counts = np.unique(lo[keep] * stride + hi[keep], return_counts=True)
    return np.column_stack([keys // stride, keys % stride]), counts


def crease_edges(vertices, topology, crease_cos=0.5) -> np.ndarray:
    """Sorted vertex pairs of the edges whose two triangles meet at more than arccos(crease_cos)
    (60 degrees: where a Solidify's rim turns in)."""
    edges, faces = topology.edge_faces
    if not len(edges):
        return edges
    n = face_normals(np.asarray(vertices, dtype=np.float64), topology.faces)
    return edges[np.einsum("ij,ij->i", n[faces[:, 0]], n[faces[:, 1]]) < crease_cos]


def used_vertices(faces: np.ndarray, n_vertices: int) -> np.ndarray:
    """Bool mask: vertices some triangle uses (a mask, not a unique: it runs on every scene build)."""
    used = np.zeros(n_vertices, dtype=bool)
    used[np.asarray(faces).ravel()] = True
    return used


def boundary_vertices(faces: np.ndarray, n_vertices: int) -> np.ndarray:
    """Bool mask: vertices on an edge that only one triangle uses (hems, cuffs, necklines)."""
    e, count = edges_with_counts(faces)
    mask = np.zeros(n_vertices, dtype=bool)
    mask[e[count == 1].ravel()] = True
    return mask


def vertex_adjacency(faces: np.ndarray, n_vertices: int, edges=None) -> sparse.csr_matrix:
    """Symmetric vertex-vertex adjacency (CSR, boolean); ``edges`` if already found."""
    return _numbered_adjacency(edges_with_counts(faces)[0] if edges is None else edges, n_vertices)[0]


def _numbered_adjacency(edges: np.ndarray, n_vertices: int):
    """(symmetric vertex-vertex adjacency, CSR boolean; per stored entry the index of its edge)."""
    ids = np.arange(1, len(edges) + 1)
    rows = np.concatenate([edges[:, 0], edges[:, 1]])
    cols = np.concatenate([edges[:, 1], edges[:, 0]])
    numbered = sparse.csr_matrix((np.concatenate([ids, ids]), (rows, cols)), shape=(n_vertices, n_vertices))
    adjacency = sparse.csr_matrix((np.ones(numbered.nnz, dtype=bool), numbered.indices, numbered.indptr),
                                  shape=(n_vertices, n_vertices))
    return adjacency, numbered.data - 1


def path_distance(adjacency: sparse.csr_matrix, lengths: np.ndarray, seeds: np.ndarray, limit: float) -> np.ndarray:
    """Length of the shortest path along edges from any start vertex, up to ``limit``; inf
    beyond. ``adjacency`` symmetric, ``lengths`` the length of each of its stored entries
    (MeshTopology.adjacency_edge maps them to edges). How far apart two points are over the
    cloth, which a fold bringing them face to face does not shorten."""
    n = adjacency.shape[0]
    seeds = np.unique(np.asarray(seeds, dtype=np.int64))
    if not len(seeds) or not limit >= 0:
        return np.full(n, np.inf)
    # a stored zero (duplicate vertices) would be no edge at all to csgraph: a hair above it
    lengths = np.maximum(lengths, 1e-12 * max(float(np.max(lengths, initial=0.0)), 1e-300))
    weighted = sparse.csr_matrix((lengths, adjacency.indices, adjacency.indptr), shape=adjacency.shape)
    return csgraph.dijkstra(weighted, directed=True, indices=seeds, limit=limit, min_only=True)


class MeshTopology:
    """What a triangle list alone decides (edges, hem points, neighbours), for meshes whose
    faces stay while their vertices move: cloth and posed garments frame after frame."""

    def __init__(self, faces: np.ndarray, n_vertices: int):
        self.faces, self.n_vertices = faces, n_vertices
        self.edges, counts = edges_with_counts(faces)
        self.hem_edges = self.edges[counts == 1]
        hem = np.zeros(n_vertices, dtype=bool)
        hem[self.hem_edges.ravel()] = True
        self.hem_vertices = np.flatnonzero(hem)
        used = used_vertices(faces, n_vertices)
        # vertices of no triangle (left behind by removed faces) cannot show: nothing moves them
        self.loose = None if used.all() else ~used
        self._adjacency = None
        self._hem_loops = None
        self._first_face = None
        self._edge_faces = None
        self._vertex_faces = None
        self.pieces = None  # per vertex its connected piece, filled by the first that needs it

    @property
    def edge_faces(self) -> tuple[np.ndarray, np.ndarray]:
        """The edges exactly two triangles share (sorted vertex pairs) and those two triangles."""
        if self._edge_faces is None:
            f = self.faces
            a, b = f.T.ravel(), f[:, [1, 2, 0]].T.ravel()
            lo, hi = np.minimum(a, b), np.maximum(a, b)
            key = lo * np.int64(max(self.n_vertices, 1)) + hi
            face = np.tile(np.arange(len(f)), 3)
            order = np.argsort(key, kind="stable")
            key, face, lo, hi = key[order], face[order], lo[order], hi[order]
            # two neighbours in key order with no third sharing their key
            pair = np.flatnonzero(key[1:] == key[:-1])
            after = np.minimum(pair + 2, len(key) - 1)
            alone = ((pair + 2 >= len(key)) | (key[after] != key[pair])) & ((pair == 0) | (key[pair - 1] != key[pair]))
            pair = pair[alone]
            self._edge_faces = (np.column_stack([lo[pair], hi[pair]]), np.column_stack([face[pair], face[pair + 1]]))
        return self._edge_faces

    @property
    def vertex_faces(self) -> tuple[np.ndarray, np.ndarray]:
        """(start, faces): the triangles of vertex v are faces[start[v]:start[v + 1]]."""
        if self._vertex_faces is None:
            corner = self.faces.ravel()
            order = np.argsort(corner, kind="stable")
            start = np.searchsorted(corner[order], np.arange(self.n_vertices + 1))
            self._vertex_faces = (start, order // 3)
        return self._vertex_faces

    @property
    def first_face(self) -> np.ndarray:
        """Per vertex the lowest-numbered triangle it is a corner of (len(faces) for none)."""
        if self._first_face is None:
            first = np.full(self.n_vertices, len(self.faces))
            np.minimum.at(first, self.faces.ravel(), np.repeat(np.arange(len(self.faces)), 3))
            self._first_face = first
        return self._first_face

    @property
    def adjacency(self) -> sparse.csr_matrix:
        """Symmetric vertex-vertex adjacency (CSR, boolean)."""
        if self._adjacency is None:
            self._build_adjacency()
        return self._adjacency

    @property
    def adjacency_edge(self) -> np.ndarray:
        """Per stored entry of ``adjacency``, the index of its edge in ``edges``."""
        if self._adjacency is None:
            self._build_adjacency()
        return self._adjacency_edge

    def _build_adjacency(self):
        self._adjacency, self._adjacency_edge = _numbered_adjacency(self.edges, self.n_vertices)

    @property
    def hem_loops(self) -> list:
        """Vertex ids of each connected set of boundary edges (a hem, cuff or neckline)."""
        if self._hem_loops is None:
            b = self.hem_edges
            self._hem_loops = []
            if len(b):
                adj = sparse.coo_matrix((np.ones(len(b)), (b[:, 0], b[:, 1])), shape=(self.n_vertices,) * 2)
                _, label = csgraph.connected_components(adj, directed=False)
                on = self.hem_vertices
                self._hem_loops = [on[label[on] == lab] for lab in np.unique(label[on])]
        return self._hem_loops


# the last few meshes' topologies, by content: a garment's next frame finds its own
TOPOLOGIES = Cache(max_entries=16)


def faces_key(faces: np.ndarray) -> bytes:
    """The content key of a triangle list, as topology_of files its topology under."""
    return digest(np.ascontiguousarray(faces, dtype=np.int64))


def topology_of(faces: np.ndarray, n_vertices: int, key: bytes | None = None) -> MeshTopology:
    """The MeshTopology of ``faces``, remembered across calls (by content) for the last few.
    ``key``: faces_key(faces), when the caller has it already."""
    key = (n_vertices, faces_key(faces) if key is None else key)
    found = TOPOLOGIES.get(key)
    if found is None:  # only then the int64 copy (Blender's faces come as int32)
        found = MeshTopology(np.ascontiguousarray(faces, dtype=np.int64), n_vertices)
        TOPOLOGIES.put(key, found)
    return found
