"""Edges the stages pull apart: drawn back under MAX_STRETCH, nothing else touched."""

import numpy as np
import pytest
import trimesh

from core.layering import resolve as resolve_module
from core.layering import resolve_layers, stretch_relax
from core.layering.stretch_relax import MAX_STRETCH, MAX_TORN, relax_stretch, shorten_torn
from tests.core.layered_cases import mesh


def _stretch(v0, v1, edges):
    a, b = edges[:, 0], edges[:, 1]
    return np.linalg.norm(v1[a] - v1[b], axis=1) / np.linalg.norm(v0[a] - v0[b], axis=1)


def test_an_edge_pulled_apart_is_drawn_back_about_its_middle_and_the_rest_stays():
    rng = np.random.default_rng(0)
    v0 = rng.random((40, 3))
    edges = np.array([[2 * i, 2 * i + 1] for i in range(20)])
    move = rng.normal(scale=0.01, size=(40, 3))
    move[0] = [5.0, 0, 0]  # edge 0 and edge 3 pulled far apart
    move[7] = [0, -4.0, 2.0]
    v1, drawn = relax_stretch(v0, v0 + move, edges)
    assert drawn == 4
    assert (_stretch(v0, v1, edges) <= MAX_STRETCH + 1e-9).all()
    kept = np.setdiff1d(np.arange(40), [0, 1, 6, 7])
    np.testing.assert_array_equal(v1[kept], (v0 + move)[kept])
    # an edge alone is drawn symmetrically: the mean of its ends' moves stays
    for a, b in ((0, 1), (6, 7)):
        np.testing.assert_allclose((v1[a] + v1[b]) / 2, (v0[a] + v0[b] + move[a] + move[b]) / 2, atol=1e-12)


def test_an_edge_a_little_over_the_limit_is_moved_a_little():
    """Continuous in the stretch: an edge 1% past MAX_STRETCH comes back to exactly the limit with
    its ends moved about 1% of its length, symmetrically (drawing the ends' moves to their mean
    moved them by most of the edge: frame to frame, an edge crossing the limit jumped)."""
    v0 = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    edges = np.array([[0, 1]])
    for over in (1.01, 1.1, 2.0):
        length = MAX_STRETCH * over
        move = np.array([[0.0, 0.3, 0.0], [length - 1.0, 0.3, 0.0]])
        v1, drawn = relax_stretch(v0, v0 + move, edges)
        assert drawn == 2
        assert _stretch(v0, v1, edges)[0] == pytest.approx(MAX_STRETCH, rel=1e-9)
        shift = np.linalg.norm(v1 - (v0 + move), axis=1)
        assert shift == pytest.approx(np.full(2, 0.5 * (length - MAX_STRETCH)), rel=1e-9)


def _wrapped_plate():
    """A plate 1 mm thick (the body), cloth wrapped round it 0.25 mm off (its rim 1.5 mm across,
    the body's normals opposite on its two faces), and a looser layer over that."""
    plate = trimesh.creation.box(extents=(0.3, 0.3, 0.001))
    body = mesh(*trimesh.remesh.subdivide_to_size(plate.vertices, plate.faces, 0.01))
    inner = trimesh.creation.box(extents=(0.2, 0.2, 0.0015))
    inner = mesh(*trimesh.remesh.subdivide_to_size(inner.vertices, inner.faces, 0.01))
    outer = trimesh.creation.box(extents=(0.21, 0.21, 0.02))
    outer = mesh(*trimesh.remesh.subdivide_to_size(outer.vertices, outer.faces, 0.01))
    return body, [inner, outer]


def test_cloth_wrapped_round_something_thin_is_lifted_without_tearing_its_rim(monkeypatch):
    body, garments = _wrapped_plate()
    edges = trimesh.Trimesh(garments[0].vertices, garments[0].faces, process=False).edges_unique
    monkeypatch.setattr(stretch_relax, "MAX_STRETCH", np.inf)
    monkeypatch.setattr(resolve_module, "MAX_TORN", np.inf)
    torn = resolve_layers(body, garments)
    assert _stretch(garments[0].vertices, torn.garments[0].vertices, edges).max() > 3.0  # the case is real
    monkeypatch.undo()
    res = resolve_layers(body, garments)
    # the lift's tears drawn back to MAX_STRETCH; what the stages after it stretch, cut at MAX_TORN
    assert _stretch(garments[0].vertices, res.garments[0].vertices, edges).max() <= MAX_TORN + 1e-6
    assert res.stats["vertices_relaxed"] > 0


def test_a_torn_edge_is_shortened_along_itself_and_no_end_goes_back_the_way_it_was_pushed():
    """Two ends pushed along opposite normals (a fold between two body parts): drawing their moves
    to the mean would undo both pushes; shortening moves each end along the edge only, to
    MAX_TORN times its length, and edges away from it stay as they were."""
    rng = np.random.default_rng(1)
    v0 = rng.random((60, 3))
    # a chain 30-31-32 and single edges elsewhere
    edges = np.array([[2 * i, 2 * i + 1] for i in range(15)] + [[30, 31], [31, 32]] + [[2 * i, 2 * i + 1]
                                                                                         for i in range(17, 30)])
    pushed = v0.copy()
    normals = rng.normal(size=(60, 3))
    normals /= np.linalg.norm(normals, axis=1)[:, None]
    pushed[[0, 1]] -= 2.0 * normals[[0, 1]]  # pushed in along diverging normals: torn
    pushed[30] -= 5.0 * normals[30]
    assert (_stretch(v0, pushed, edges[[0, 15]]) > MAX_TORN).all()  # (0, 1) and (30, 31) torn
    out, drawn = shorten_torn(v0, pushed, edges, MAX_TORN)
    assert (_stretch(v0, out, edges) <= MAX_TORN * (1 + 1e-6)).all()
    touched = np.flatnonzero((out != pushed).any(axis=1))
    assert drawn == len(touched) and set(touched) <= {0, 1, 30, 31, 32}
    # the edge torn alone: its ends move towards each other along it to exactly MAX_TORN, the middle stays
    along = (pushed[1] - pushed[0]) / np.linalg.norm(pushed[1] - pushed[0])
    np.testing.assert_allclose((out[0] + out[1]) / 2, (pushed[0] + pushed[1]) / 2, atol=1e-12)
    for end in (0, 1):
        shift = out[end] - pushed[end]
        np.testing.assert_allclose(shift, along * (shift @ along), atol=1e-12)
    assert _stretch(v0, out, edges[:1])[0] == pytest.approx(MAX_TORN, rel=1e-9)
