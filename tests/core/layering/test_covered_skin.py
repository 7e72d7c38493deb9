"""Skin under cloth (core.layering.covered_skin) against every (ray, triangle) pair tested."""

import numpy as np
import pytest

from core.geometry.normals import vertex_normals
from core.layering import resolve_layers
from core.layering.covered_skin import covered_faces
from sample_scenes.shapes import tube
from tests.core.brute import moller_trumbore
from tests.core.layered_cases import body_tube, mesh


def _brute(bv, bf, cloth, reach_out, reach_in):
    cv, cf = cloth
    a, b, c = (bv[bf[:, k]] for k in range(3))
    face_n = np.cross(b - a, c - a)
    face_n /= np.linalg.norm(face_n, axis=1, keepdims=True)
    points = np.vstack([bv, (a + b + c) / 3])
    normals = np.vstack([vertex_normals(bv, bf), face_n])
    reach = np.concatenate([np.full(len(bv), reach_out), np.full(len(bf), reach_out)])
    _, face = moller_trumbore(points - normals * reach_in, normals, cv, cf, 0.0, reach + reach_in)
    over = face >= 0
    return over[bf].all(axis=1) & over[len(bv):]


@pytest.mark.parametrize("radius", [0.149, 0.152, 0.16])  # a little inside the skin, on it, 1 cm out
def test_faces_under_a_sleeve_are_covered_and_those_past_its_hems_are_not(radius):
    body = body_tube(n=32)
    bv, bf = np.asarray(body.vertices), np.asarray(body.faces)
    # hems clear of the body's rings, columns never in line with its own: no ray through an edge
    cloth = tube(radius, 0.21, 0.39, grid=(23, 8))
    got = covered_faces(bv, bf, [cloth], 0.03, 0.005)
    np.testing.assert_array_equal(got, _brute(bv, bf, cloth, 0.03, 0.005))
    # with the body normals a resolve of the same body found (what Hide Covered Skin passes)
    found = resolve_layers(body, [mesh(*cloth)]).history.body_normals
    np.testing.assert_array_equal(covered_faces(bv, bf, [cloth], 0.03, 0.005, normals=found), got)
    centre_z = bv[bf].mean(axis=1)[:, 2]
    on_side = np.abs(np.hypot(*bv[bf].mean(axis=1)[:, :2].T) - 0.15) < 0.01
    assert got[on_side & (centre_z > 0.23) & (centre_z < 0.37)].all()
    assert not got[(centre_z < 0.18) | (centre_z > 0.42)].any()


def test_cloth_out_of_reach_or_deep_inside_covers_nothing():
    body = body_tube(n=32)
    bv, bf = np.asarray(body.vertices), np.asarray(body.faces)
    for radius in (0.2, 0.13):  # 5 cm out with a 3 cm reach; 2 cm in with 5 mm
        assert not covered_faces(bv, bf, [tube(radius, 0.2, 0.4, grid=(24, 8))], 0.03, 0.005).any()
    assert not covered_faces(bv, bf, [], 0.03, 0.005).any()


def test_skin_within_the_margin_of_an_opening_stays():
    body = body_tube(n=32)
    bv, bf = np.asarray(body.vertices), np.asarray(body.faces)
    cloth = tube(0.152, 0.21, 0.39, grid=(23, 8))
    plain = covered_faces(bv, bf, [cloth], 0.03, 0.005)
    kept_back = covered_faces(bv, bf, [cloth], 0.03, 0.005, margin=0.03)
    assert plain.any() and kept_back.any() and not (kept_back & ~plain).any()
    # over the body's side the path from a covered face to the nearest open one runs up or down it
    centre_z = bv[bf].mean(axis=1)[:, 2]
    open_z = centre_z[~plain & (centre_z > 0.05) & (centre_z < 0.55)]
    gap = np.abs(centre_z[:, None] - open_z[None, :]).min(axis=1)
    assert not kept_back[gap < 0.03].any()
    assert kept_back[plain & (gap > 0.03 + 0.04)].all()  # (a face spans 4 cm of height)


def test_the_margin_keeps_each_face_with_a_corner_near_open_skin_along_the_surface():
    """Against scipy's Dijkstra over the body's edges from every corner of a face left open: a
    covered face stays when any of its three corners lies within the margin of one."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    body = body_tube(n=32)
    bv, bf = np.asarray(body.vertices), np.asarray(body.faces)
    cloth = tube(0.152, 0.21, 0.39, grid=(23, 8))
    margin = 0.03
    plain = covered_faces(bv, bf, [cloth], 0.03, 0.005)
    kept = covered_faces(bv, bf, [cloth], 0.03, 0.005, margin=margin)
    pairs = np.unique(np.sort(np.vstack([bf[:, [0, 1]], bf[:, [1, 2]], bf[:, [2, 0]]]), axis=1), axis=0)
    length = np.linalg.norm(bv[pairs[:, 0]] - bv[pairs[:, 1]], axis=1)
    graph = coo_matrix((length, (pairs[:, 0], pairs[:, 1])), shape=(len(bv), len(bv))).tocsr()
    seeds = np.unique(bf[~plain])
    near = dijkstra(graph, directed=False, indices=seeds, min_only=True, limit=margin) <= margin
    want = plain & ~near[bf].any(axis=1)
    assert (plain & ~want).any() and want.any()  # the margin takes some covered faces back, not all
    np.testing.assert_array_equal(kept, want)
