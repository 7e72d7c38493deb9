"""core.metrics crossings against brute-force segment-triangle tests."""

import numpy as np
import pytest
import trimesh

from core.layering.metrics import crossings, layer_crossings, self_crossing_edges
from tests.core.brute import brute_crossings, brute_self_crossings


def test_two_spheres_cross_on_a_circle():
    a = trimesh.creation.icosphere(subdivisions=3)
    b = trimesh.creation.icosphere(subdivisions=3)
    b.apply_translation([1.0, 0.2, 0.1])
    n = crossings(a.vertices, a.faces, b.vertices, b.faces)
    assert n == brute_crossings(a.vertices, a.faces, b.vertices, b.faces)
    assert n > 20


def test_nested_spheres_do_not_cross():
    a = trimesh.creation.icosphere(subdivisions=3)
    b = trimesh.creation.icosphere(subdivisions=3, radius=1.05)
    assert crossings(a.vertices, a.faces, b.vertices, b.faces) == 0


def test_layer_matrix_is_symmetric_and_matches_pairs():
    rng = np.random.default_rng(3)
    layers = []
    for k in range(3):
        m = trimesh.creation.icosphere(subdivisions=2, radius=1.0 + 0.01 * k)
        layers.append((m.vertices + rng.normal(scale=0.02, size=m.vertices.shape), m.faces))
    mat = layer_crossings(layers)
    assert (mat == mat.T).all() and (np.diag(mat) == 0).all()
    assert mat[0, 1] == brute_crossings(*layers[0], *layers[1])
    assert mat[0, 1] > 0


def test_empty_and_degenerate_meshes():
    a = trimesh.creation.icosphere(subdivisions=1)
    assert crossings(a.vertices, a.faces, np.zeros((0, 3)), np.zeros((0, 3), int)) == 0
    # zero-length edges (a collapsed triangle) are skipped, not crossing
    v = np.array([[0, 0, 0], [0, 0, 0], [0, 0, 0]], float)
    assert crossings(a.vertices, a.faces, v, [[0, 1, 2]]) == 0


def ray_sphere_t(o, d, r):
    """Distance to the first intersection with a sphere of radius r at the origin (inf on miss)."""
    d = d / np.linalg.norm(d, axis=1, keepdims=True)
    b = np.einsum("ij,ij->i", o, d)
    c = np.einsum("ij,ij->i", o, o) - r * r
    disc = b * b - c
    with np.errstate(invalid="ignore"):
        return np.where(disc > 0, -b - np.sqrt(disc), np.inf)


def test_poke_through_zero_when_ordered_and_analytic_when_reversed():
    from core.layering.metrics import camera_ring, poke_through

    inner = trimesh.creation.icosphere(subdivisions=4, radius=1.0)
    outer = trimesh.creation.icosphere(subdivisions=4, radius=1.05)
    cams = camera_ring([0, 0, 0], 1.05, views=4, resolution=64)
    share, poked, covered = poke_through([(inner.vertices, inner.faces), (outer.vertices, outer.faces)],
                                         depth=0.2, cameras=cams)
    assert poked == 0 and covered > 0
    # labelled the wrong way round, the outer sphere is "lower": every pixel over the inner
    # sphere shows it poking through; compare with exact ray-sphere coverage
    share, _, _ = poke_through([(outer.vertices, outer.faces), (inner.vertices, inner.faces)],
                               depth=0.2, cameras=cams)
    t_out = np.concatenate([ray_sphere_t(o, d, 1.05) for o, d in cams])
    t_in = np.concatenate([ray_sphere_t(o, d, 1.0) for o, d in cams])
    with np.errstate(invalid="ignore"):
        expected = (t_in - t_out <= 0.2).sum() / np.isfinite(t_out).sum()
    assert share == pytest.approx(expected, abs=0.01)  # tessellation of the spheres
    # a short depth sees nothing: the spheres are 0.05 apart
    assert poke_through([(outer.vertices, outer.faces), (inner.vertices, inner.faces)],
                        depth=0.03, cameras=cams)[1] == 0


def test_new_holes_limits():
    from core.layering.metrics import new_holes

    inner = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    outer = trimesh.creation.icosphere(subdivisions=3, radius=1.05)
    layers = [(inner.vertices, inner.faces), (outer.vertices, outer.faces)]
    assert new_holes(layers, layers) == 0
    # removing the hidden inner layer opens nothing
    assert new_holes(layers, [(inner.vertices, inner.faces[:0]), layers[1]]) == 0
    # removing everything opens everything
    assert new_holes(layers, [(inner.vertices, inner.faces[:0]), (outer.vertices, outer.faces[:0])]) == 1.0
    # removing the outer layer reveals the lower one everywhere: all holes
    assert new_holes(layers, [layers[0], (outer.vertices, outer.faces[:0])]) == 1.0


def test_distortion_of_a_uniform_scale():
    from core.layering.metrics import distortion

    m = trimesh.creation.icosphere(subdivisions=2)
    out = distortion(m.vertices, m.vertices * 1.1, m.faces)
    assert out["max_stretch"] == pytest.approx(1.1)
    assert out["max_move"] == pytest.approx(0.1)
    assert out["max_move_rel"] == pytest.approx(0.1 / np.linalg.norm(np.ptp(m.vertices, axis=0)))
    assert out["p99_stretch"] == pytest.approx(1.1)


def test_one_pulled_vertex_stretches_its_edges_not_the_cloth():
    """The largest stretch is the pulled vertex's edges; 99% of the edges are as they were."""
    from core.layering.metrics import distortion, unique_edges

    m = trimesh.creation.icosphere(subdivisions=3)
    after = m.vertices.copy()
    after[0] *= 1.5
    out = distortion(m.vertices, after, m.faces)
    e = unique_edges(m.faces)
    l0, l1 = (np.linalg.norm(v[e[:, 0]] - v[e[:, 1]], axis=1) for v in (m.vertices, after))
    assert out["max_stretch"] == pytest.approx((l1 / l0).max())
    assert out["max_stretch"] > 2.0 and out["p99_stretch"] == pytest.approx(1.0)


def test_removed_area_share_of_half_a_square():
    from core.layering.metrics import removed_area_share

    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    f = np.array([[0, 1, 2], [0, 2, 3]])
    assert removed_area_share(v, f, np.array([True, False])) == pytest.approx(0.5)
    assert removed_area_share(v, f[:0], np.zeros(0, bool)) == 0.0


def _down_rays(n=12, size=0.6, z=1.0):
    s = np.linspace(-size / 2, size / 2, n)
    x, y = np.meshgrid(s, s)
    o = np.column_stack([x.ravel(), y.ravel(), np.full(x.size, z)])
    return o, np.tile([0.0, 0.0, -1.0], (len(o), 1))


def test_poke_through_takes_the_higher_layers_given_normals_not_their_winding_nor_another_layers():
    """A lower sheet 1 cm over a higher one, seen from above: it pokes through where the higher
    one faces the camera. The higher sheet is wound facing away, but its given normals face up;
    the lower one's given normals face down (a lookup in the wrong layer reads those)."""
    from core.layering.metrics import poke_through
    from tests.core.layered_cases import sheet

    lower = sheet(size=1.0, n=20, z=0.01)
    v, f = sheet(size=1.0, n=20, z=0.0)
    higher = (v, f[:, ::-1])  # winding facing down
    up, down = np.tile([0.0, 0.0, 1.0], (len(v), 1)), np.tile([0.0, 0.0, -1.0], (len(v), 1))
    cams = [_down_rays()]
    share, poked, covered = poke_through([lower, higher], normals=[down, up], depth=0.05, cameras=cams)
    assert covered == 144 and poked == covered and share == 1.0
    assert poke_through([lower, higher], depth=0.05, cameras=cams)[1] == 0  # by winding: it faces away
    assert poke_through([lower, higher], normals=[up, down], depth=0.05, cameras=cams)[1] == 0


def test_a_higher_layer_revealed_by_removing_faces_is_no_hole_and_the_background_is():
    from core.layering.metrics import new_holes
    from tests.core.layered_cases import sheet

    lower, higher = sheet(size=1.0, n=20, z=0.01), sheet(size=1.0, n=20, z=0.0)
    cams = [_down_rays()]
    cut = (lower[0], lower[1][: len(lower[1]) // 2])  # half the lower sheet's triangles gone
    assert new_holes([lower, higher], [cut, higher], cameras=cams) == 0.0  # the higher one shows
    alone = new_holes([lower, higher], [cut, (higher[0], higher[1][:0])], cameras=cams)
    assert 0.3 < alone < 0.7  # with nothing under, about half the pixels now show the background


def test_the_camera_ring_frames_its_sphere_whole_and_close():
    """Each view sees the whole sphere it frames (every ray on the image's border misses it) and
    fills most of the image with it: the share of rays that meet it is the analytic disc over
    square (pi/4 (tan a / tan h)^2, a the sphere's angular radius from 3 radii, h = 1.05 a: 5% of
    margin)."""
    from core.layering.metrics import camera_ring

    r, res = 0.7, 96
    for origins, dirs in camera_ring([0.2, -0.1, 1.0], r, views=3, resolution=res):
        t = ray_sphere_t(origins - [0.2, -0.1, 1.0], dirs / np.linalg.norm(dirs, axis=1, keepdims=True), r)
        hit = np.isfinite(t).reshape(res, res)
        assert not hit[0].any() and not hit[-1].any() and not hit[:, 0].any() and not hit[:, -1].any()
        a = np.arcsin(1 / 3)
        expected = np.pi / 4 * (np.tan(a) / np.tan(1.05 * a)) ** 2
        assert hit.mean() == pytest.approx(expected, rel=0.03)


def test_poke_through_looks_two_percent_of_the_scene_behind_by_default():
    """A lower square in front of a higher one (it shows through): counted when it lies 1% of the
    scene's radius in front, not when 3% (the default depth is 2% of the radius)."""
    from core.layering.metrics import camera_ring, layer_bounds, poke_through

    def square(z, half=0.5):
        v = np.array([[-half, -half, z], [half, -half, z], [half, half, z], [-half, half, z]], float)
        return v, np.array([[0, 1, 2], [0, 2, 3]])

    def share(gap):
        layers = [square(1.0), square(1.0 - gap, half=0.6)]  # the higher layer behind the lower, seen from +z
        center, radius = layer_bounds(layers)
        cams = [c for c in camera_ring(center, radius, views=1, elevations_deg=(89.9,), resolution=48)]
        return poke_through(layers, cameras=cams)[0], radius

    _, radius = share(0.0)
    near, _ = share(0.01 * radius)
    far, _ = share(0.03 * radius)
    assert near > 0.5 and far == 0.0


def test_the_99th_percentile_stretch_sees_a_seam_that_is_three_percent_of_the_edges():
    """100 separate triangles, 5 of them with one corner pulled: 10 of 300 edges (3.3%) stretch
    by the same ratio R, so the 99th percentile is R (and the 90th would be 1)."""
    from core.layering.metrics import distortion

    tri = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    v0 = np.vstack([tri + [3 * k, 0, 0] for k in range(100)])
    f = np.arange(300).reshape(100, 3)
    v1 = v0.copy()
    v1[[3 * k for k in range(5)]] -= [1.0, 1.0, 0.0]  # corner 0 of five triangles moved 1 down-left
    ratio = np.linalg.norm(tri[1] - (tri[0] - [1, 1, 0])) / 1.0  # both edges at corner 0: sqrt(5)
    out = distortion(v0, v1, f)
    assert out["p99_stretch"] == pytest.approx(ratio) and out["max_stretch"] == pytest.approx(ratio)


def _sheet(n=16):
    """A flat square sheet of n x n vertices."""
    x, y = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    v = np.column_stack([x.ravel(), y.ravel(), np.zeros(n * n)])
    i = np.arange(n - 1)
    a = (i[:, None] * n + i[None, :]).ravel()
    return v, np.concatenate([np.column_stack([a, a + 1, a + n + 1]), np.column_stack([a, a + n + 1, a + n])])


def test_self_crossings_of_a_sphere_pulled_through_itself_match_brute_force():
    # one vertex pulled through to beyond the far side: its edges pass through the sphere there
    s = trimesh.creation.icosphere(subdivisions=2)
    v = s.vertices.copy()
    v[7] *= -1.4
    found = self_crossing_edges(v, s.faces)
    assert (found == brute_self_crossings(v, s.faces)).all()
    assert found.sum() >= 5
    # two separate pieces of one mesh cut through each other: each crosses the other
    a, f = _sheet(8)
    b = a[:, [0, 2, 1]] + [0.0, 0.5, -0.5]  # the same sheet stood up across the first
    v2, f2 = np.vstack([a, b]), np.vstack([f, f + len(a)])
    found = self_crossing_edges(v2, f2)
    assert (found == brute_self_crossings(v2, f2)).all()
    assert found.sum() > 10


def test_flat_and_closed_meshes_do_not_cross_themselves():
    # a flat sheet's rays run in the plane of their neighbours (Embree reports grazing contacts there)
    assert not self_crossing_edges(*_sheet()).any()
    s = trimesh.creation.icosphere(subdivisions=3)
    assert not self_crossing_edges(s.vertices, s.faces).any()
    rng = np.random.default_rng(1)  # a rough but untangled sphere: neighbours' faces are passed over
    rough = s.vertices * (1 + 0.01 * rng.normal(size=(len(s.vertices), 1)))
    assert (self_crossing_edges(rough, s.faces) == brute_self_crossings(rough, s.faces)).all()
