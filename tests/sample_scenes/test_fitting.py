"""Garment cutting for the sample scenes (numpy parts): covers, scraps, clearance, hull tubes."""

import numpy as np
import pytest
from deformrt.sample_scenes import figures, fitting
from scipy.spatial import ConvexHull

from sample_scenes.shapes import tube


def test_polygon_radius_of_a_square_is_analytic():
    sq = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]], float)
    theta = np.array([0, np.pi / 4, np.pi / 2, np.pi / 6])
    np.testing.assert_allclose(fitting._polygon_radius(sq, theta), [1, np.sqrt(2), 1, 1 / np.cos(np.pi / 6)])


def test_clear_of_body_moves_only_points_too_close_and_to_exactly_the_gap():
    rng = np.random.default_rng(0)
    v, f = tube(1.0, -1.0, 1.0, grid=(256, 64), capped=True)
    d = rng.normal(size=(500, 3))
    d[:, 2] = 0
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    r = rng.uniform(0.9, 1.1, 500)
    p = d * r[:, None] + np.column_stack([np.zeros((500, 2)), rng.uniform(-0.5, 0.5, 500)])
    out = fitting.clear_of_body(p, v, f, 0.02)
    r_out = np.linalg.norm(out[:, :2], axis=1)
    far = r >= 1.02 + 1e-3
    np.testing.assert_array_equal(out[far], p[far])
    # the faceted cylinder's surface lies between cos(pi/256) and 1
    assert (r_out > np.cos(np.pi / 256) + 0.02 - 1e-9).all() and (r_out[~far] < 1.02 + 1e-3).all()


def test_keep_faces_drops_scraps_and_renumbers():
    v, f = tube(1.0, 0.0, 1.0, grid=(32, 10))
    keep = np.ones(len(v), bool)
    keep[4 * 32:5 * 32] = False  # cut a ring: two tubes remain
    keep[2 * 32 + 5] = False
    used, faces = fitting.keep_faces(f, keep)
    assert faces.max() == len(used) - 1 and keep[used].all()
    assert len(faces) == (f[keep[f].all(1)]).shape[0]
    # a lone triangle far from the rest is a scrap
    v2 = np.vstack([v, [[5, 5, 5], [5, 6, 5], [6, 5, 5]]])
    f2 = np.vstack([f, [[len(v), len(v) + 1, len(v) + 2]]])
    used2, faces2 = fitting.keep_faces(f2, np.ones(len(v2), bool))
    assert len(faces2) == len(f) and len(v) not in used2


def test_wooden_cuts_cover_what_their_names_say():
    fig = figures.wooden()
    part = fitting.body_parts(fig)
    v = fig.vertices
    pants = fitting.cover_mask(v, part, fig, fitting.CUTS["pants"])
    shirt = fitting.cover_mask(v, part, fig, fitting.CUTS["shirt"])
    tshirt = fitting.cover_mask(v, part, fig, fitting.CUTS["tshirt"])
    z = v[:, 2]
    head = z > fig.heights["neck"] + 0.05
    feet = z < 0.05
    assert not (pants & head).any() and not (shirt & head).any() and not (pants & feet).any()
    knee = np.abs(z - fig.heights["knee"]) < 0.02
    assert pants[knee].mean() > 0.9 and not shirt[knee].any()
    wrist_x = abs(fig.joints[fig.joint_names.index("L_Wrist"), 0])
    forearm = (np.abs(v[:, 0]) > 0.6 * wrist_x) & (np.abs(v[:, 0]) < 0.8 * wrist_x)
    assert shirt[forearm].mean() > 0.9 and not tshirt[forearm].any()


def test_skirt_tube_contains_the_hips_and_legs_at_every_height():
    fig = figures.wooden()
    part = fitting.body_parts(fig)
    v, f = fitting.tube_garment(fig, part, fitting.CUTS["skirt"], ease=0.01, edge=0.01)
    legs = np.isin(part, [0, 7, 8, 9, 10])
    rows = np.unique(np.round(v[:, 2], 9))
    for zi in rows[1:-1:5]:
        ring = v[np.abs(v[:, 2] - zi) < 1e-9, :2]
        body = fig.vertices[legs & (np.abs(fig.vertices[:, 2] - zi) < 0.003), :2]
        if len(body) < 3:
            continue
        hull = ConvexHull(ring)
        # every body point inside the ring: all hull facet equations negative
        assert (body @ hull.equations[:, :2].T + hull.equations[:, 2] < 0).all()
    with pytest.raises(ValueError, match="must be above"):
        fitting.tube_garment(fig, part, fitting.Tube(("knee", 0.0), ("waist", 0.0)), 0.01, 0.01)


def test_untangle_smooths_a_fold_through_itself_away_and_leaves_the_rest():
    import trimesh

    from core.layering.metrics import self_crossing_edges
    s = trimesh.creation.icosphere(subdivisions=3)
    v = s.vertices.copy()
    v[7] *= -1.4  # pulled through to beyond the far side
    assert self_crossing_edges(v, s.faces).sum() > 0
    out, left = fitting.untangle(v, s.faces)
    assert left == 0 and not self_crossing_edges(out, s.faces).any()
    # only round the pulled vertex and where its edges passed through moved
    moved = np.linalg.norm(out - v, axis=1) > 0
    assert 0 < moved.sum() < 0.25 * len(v)
    near = (np.linalg.norm(v - v[7], axis=1) < 0.8) | (np.linalg.norm(v - s.vertices[7], axis=1) < 0.8)
    assert not (moved & ~near).any()
    # an untangled mesh comes back as it was
    same, left = fitting.untangle(s.vertices, s.faces)
    assert left == 0 and np.array_equal(same, s.vertices)


def test_untangle_unfolds_a_pleat_folded_flat_over_itself():
    # a wavy sheet whose one vertex slid past its neighbours: the triangles round it face backwards
    n = 12
    x, y = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    v = np.column_stack([x.ravel(), y.ravel(), 0.02 * np.sin(6 * x.ravel())])
    i = np.arange(n - 1)
    a = (i[:, None] * n + i[None, :]).ravel()
    f = np.concatenate([np.column_stack([a, a + 1, a + n + 1]), np.column_stack([a, a + n + 1, a + n])])
    assert not fitting.folded_faces(v, f).any()
    k = 5 * n + 5
    v[k, :2] += [0.16, 0.16]  # past the next vertex in both directions
    assert fitting.folded_faces(v, f).sum() >= 2
    out, left = fitting.untangle(v, f)
    assert left == 0 and not fitting.folded_faces(out, f).any()
    far = np.linalg.norm(v[:, :2] - v[k, :2], axis=1) > 0.5
    np.testing.assert_array_equal(out[far], v[far])
