"""Face and vertex normals of triangle meshes."""

import numpy as np

from .vectors import cross, norms, rows, unit


def face_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Unit geometric normal per triangle in its winding order (zero for a degenerate one)."""
    a, b, c = (rows(vertices, np.asarray(faces)[:, k]) for k in range(3))
    return unit(cross(b - a, c - a))


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Area-weighted unit vertex normals (zero for vertices of zero-area triangles only)."""
    return vertex_normals_and_area(vertices, faces)[0]


def vertex_normals_and_area(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, float]:
    """(``vertex_normals``, the triangles' total area): the area comes with the normals' cross
    products for next to nothing."""
    f = np.asarray(faces)
    if not len(vertices) or not len(f):
        return np.zeros((len(vertices), 3)), 0.0
    a, b, c = (rows(vertices, f[:, k]) for k in range(3))
    area = cross(b - a, c - a)
    # bincount per axis: several times faster than np.add.at
    idx = f.T.ravel()
    out = np.empty((len(vertices), 3))
    for k in range(3):
        out[:, k] = np.bincount(idx, weights=np.tile(area[:, k], 3), minlength=len(vertices))
    return unit(out), 0.5 * float(norms(area).sum())
