"""Nearest body points, global normals and local radius against independent answers."""

import numpy as np
import pytest
import trimesh

import core.layering.correspondence as correspondence
from core.geometry.normals import vertex_normals
from core.layering.correspondence import closest_point_on_triangles, local_radius, nearest_on_surface, surface_search
from sample_scenes.shapes import tube

# Both searches: fcpw's BVH (bundled) picks in float32 about the body's centre, exact to about 1e-7
# of the body's size; the candidate search (without fcpw) measures its candidates in float64.
SEARCHES = [pytest.param("bvh", 1e-7, marks=pytest.mark.skipif(correspondence._fcpw is None, reason="no fcpw")),
            ("candidates", 1e-9)]


def searched(kind, v, f):
    search = surface_search(v, f)
    return search if kind == "bvh" else search._replace(bvh=None)


def bumpy_body(seed=0, subdivisions=3):
    m = trimesh.creation.icosphere(subdivisions=subdivisions)
    rng = np.random.default_rng(seed)
    k = rng.normal(size=(3, 3))
    bump = sum(0.05 * np.sin(m.vertices @ k[i] * 2 + i) for i in range(3))
    return m.vertices * (1 + bump)[:, None], m.faces


@pytest.mark.parametrize("kind, tol", SEARCHES)
def test_nearest_point_matches_trimesh_proximity(kind, tol):
    v, f = bumpy_body()
    rng = np.random.default_rng(1)
    pts = rng.normal(size=(400, 3))
    pts *= rng.uniform(0.8, 1.4, (400, 1)) / np.linalg.norm(pts, axis=1, keepdims=True)
    ours = nearest_on_surface(pts, v, f, search=searched(kind, v, f))
    _, ref_d, _ = trimesh.proximity.closest_point(trimesh.Trimesh(v, f, process=False), pts)
    np.testing.assert_allclose(ours.distance, ref_d, atol=tol)
    # the point named is that far (where two triangles tie, either is the nearest point)
    np.testing.assert_allclose(np.linalg.norm(pts - ours.points(v, f), axis=1), ours.distance, atol=1e-12)
    assert np.allclose(ours.bary.sum(1), 1) and (ours.bary >= -1e-12).all()


def test_vertices_of_no_triangle_do_not_hide_the_surface():
    """Loose body vertices (left over by modelling) sit right at the query points; the answer is
    still the nearest point on the triangles."""
    v, f = bumpy_body()
    rng = np.random.default_rng(2)
    pts = rng.normal(size=(300, 3))
    pts *= 1.2 / np.linalg.norm(pts, axis=1, keepdims=True)
    loose = np.vstack([pts + 1e-4, pts - 1e-4])  # the two nearest vertices of every point
    ours = nearest_on_surface(pts, np.vstack([v, loose]), f)
    _, ref_d, _ = trimesh.proximity.closest_point(trimesh.Trimesh(v, f, process=False), pts)
    np.testing.assert_allclose(ours.distance, ref_d, atol=1e-9)


def test_a_few_huge_triangles_beside_fine_ones_are_still_found():
    """A figure on a floor of two triangles 4 m across (a collider, a stage): over most of the
    floor the nearest vertices are the figure's or the floor's far corners, neither of which
    names the floor under the point."""
    v, f = bumpy_body()
    floor_v = np.array([[-2.0, -2.0, -1.3], [2.0, -2.0, -1.3], [2.0, 2.0, -1.3], [-2.0, 2.0, -1.3]])
    floor_f = np.array([[0, 1, 2], [0, 2, 3]]) + len(v)
    verts, faces = np.vstack([v, floor_v]), np.vstack([f, floor_f])
    rng = np.random.default_rng(3)
    pts = np.column_stack([rng.uniform(-1.9, 1.9, (500, 2)), rng.uniform(-1.29, -0.5, 500)])
    ours = nearest_on_surface(pts, verts, faces)
    ref_pts, ref_d, _ = trimesh.proximity.closest_point(trimesh.Trimesh(verts, faces, process=False), pts)
    np.testing.assert_allclose(ours.distance, ref_d, atol=1e-9)
    np.testing.assert_allclose(ours.points(verts, faces), ref_pts, atol=1e-7)


def test_closest_point_regions_against_dense_sampling():
    rng = np.random.default_rng(2)
    a, b, c = (rng.normal(size=(200, 3)) for _ in range(3))
    p = rng.normal(size=(200, 3)) * 2
    w = closest_point_on_triangles(p, a, b, c)
    q = w[:, :1] * a + w[:, 1:2] * b + w[:, 2:] * c
    # brute force: a fine barycentric grid on each triangle
    s = np.linspace(0, 1, 201)
    uu, vv = np.meshgrid(s, s)
    keep = uu + vv <= 1
    uu, vv = uu[keep], vv[keep]
    grid = (1 - uu - vv)[None, :, None] * a[:, None] + uu[None, :, None] * b[:, None] + vv[None, :, None] * c[:, None]
    d_ref = np.linalg.norm(grid - p[:, None], axis=2).min(1)
    d = np.linalg.norm(q - p, axis=1)
    assert (d <= d_ref + 1e-12).all()  # never worse than any sampled point
    assert np.allclose(d, d_ref, atol=0.02)


def test_degenerate_triangles_stay_finite():
    a = np.zeros((3, 3))
    b = np.array([[0, 0, 0], [1, 0, 0], [1, 0, 0]], float)
    c = np.array([[0, 0, 0], [2, 0, 0], [0.5, 0, 0]], float)
    p = np.array([[0, 1, 0], [1, 1, 0], [0.5, -1, 0]], float)
    w = closest_point_on_triangles(p, a, b, c)
    assert np.isfinite(w).all()
    q = w[:, :1] * a + w[:, 1:2] * b + w[:, 2:] * c
    np.testing.assert_allclose(q[0], [0, 0, 0])
    np.testing.assert_allclose(q[1], [1, 0, 0])
    np.testing.assert_allclose(q[2], [0.5, 0, 0])


def test_global_normals_of_a_sphere_point_radially():
    m = trimesh.creation.icosphere(subdivisions=4)
    rng = np.random.default_rng(3)
    pts = rng.normal(size=(300, 3))
    pts *= 1.1 / np.linalg.norm(pts, axis=1, keepdims=True)
    corr = nearest_on_surface(pts, m.vertices, m.faces)
    n = corr.normals(vertex_normals(m.vertices, m.faces), m.faces)
    radial = pts / np.linalg.norm(pts, axis=1, keepdims=True)
    assert np.einsum("ij,ij->i", n, radial).min() > 0.999


@pytest.mark.parametrize("radius", [0.05, 1.0, 300.0])
def test_local_radius_of_a_cylinder_is_its_radius(radius):
    v, f = tube(radius, 0.0, 10 * radius, grid=(64, 40), capped=True)
    r = local_radius(v, f)
    # away from the caps the chord through the axis is the diameter (the polygon's, 0.1% short)
    side = (v[:, 2] > radius) & (v[:, 2] < 9 * radius)
    np.testing.assert_allclose(r[side], radius, rtol=0.005)
    assert np.isfinite(r).all()


@pytest.mark.parametrize("kind, tol", SEARCHES)
def test_nearest_point_over_many_pieces_on_two_threads_matches_trimesh(monkeypatch, kind, tol):
    """More points than one piece of the candidates' test holds, on every slice of two threads:
    each piece writes its own points' answers and no other's."""
    import core.layering.correspondence as corr

    monkeypatch.setenv("DEFORMRT_THREADS", "2")
    monkeypatch.setattr(corr, "_SEARCH_BLOCK", 97)
    monkeypatch.setattr(corr, "_CHUNK", 64)
    v, f = bumpy_body(subdivisions=2)
    rng = np.random.default_rng(7)
    pts = rng.normal(size=(3001, 3))
    pts *= rng.uniform(0.8, 1.4, (3001, 1)) / np.linalg.norm(pts, axis=1, keepdims=True)
    ours = nearest_on_surface(pts, v, f, search=searched(kind, v, f))
    _, ref_d, _ = trimesh.proximity.closest_point(trimesh.Trimesh(v, f, process=False), pts)
    # a point on the surface as far as the nearest is a nearest point (at ties, any of them)
    np.testing.assert_allclose(np.linalg.norm(pts - ours.points(v, f), axis=1), ref_d, atol=tol)
    np.testing.assert_allclose(ours.distance, ref_d, atol=tol)
    assert np.allclose(ours.bary.sum(1), 1) and (ours.bary >= -1e-12).all()


@pytest.mark.parametrize("angle_deg", [0.5, 2.0, 5.0, 8.0])
def test_slivers_are_measured_to_their_plane(angle_deg):
    """Thin triangles (one corner angle of a few degrees) with points over their inside: the
    nearest point is in the plane, not on an edge (trimesh's own query as the reference)."""
    rng = np.random.default_rng(int(angle_deg * 10))
    n = 300
    a = rng.normal(size=(n, 3))
    u = rng.normal(size=(n, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    w = np.cross(u, rng.normal(size=(n, 3)))
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    theta = np.radians(angle_deg)
    b = a + u
    c = a + 1.2 * (np.cos(theta) * u + np.sin(theta) * w)
    inside = a + 0.5 * (b - a) * 0.6 + 0.5 * (c - a) * 0.6
    normal = np.cross(b - a, c - a)
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    p = inside + normal * rng.uniform(0.01, 0.2, (n, 1))
    wts = closest_point_on_triangles(p, a, b, c)
    ours = wts[:, :1] * a + wts[:, 1:2] * b + wts[:, 2:] * c
    ref = trimesh.triangles.closest_point(np.stack([a, b, c], axis=1), p)
    np.testing.assert_allclose(ours, ref, atol=1e-9)
