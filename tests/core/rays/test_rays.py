"""RayScene against a brute-force float64 Möller–Trumbore."""

import warnings

import numpy as np
import pytest
import trimesh

from core.rays import RayScene, SceneUnion, embree, embree_direct, numpy_backend
from tests.core.brute import edge_margin, moller_trumbore


def random_soup(rng, n_tri=300, scale=1.0, offset=0.0):
    centers = rng.uniform(-1, 1, (n_tri, 1, 3))
    tri = centers + rng.normal(scale=0.15, size=(n_tri, 3, 3))
    v = (tri.reshape(-1, 3) * scale) + offset
    return v, np.arange(len(v)).reshape(-1, 3)


def random_rays(rng, n, scale=1.0, offset=0.0):
    o = rng.uniform(-1.5, 1.5, (n, 3)) * scale + offset
    d = rng.normal(size=(n, 3))
    return o, d


def assert_matches_brute(scene, v, f, o, d, tmin=0.0, tmax=np.inf, rtol=1e-6):
    got = scene.intersect(o, d, max_dist=None if np.isinf(np.max(tmax)) else tmax,
                          min_dist=tmin)
    t_ref, f_ref = moller_trumbore(o, d, v, f, tmin, tmax)
    size = np.ptp(v, axis=0).max() if len(v) else 1.0
    # Rays whose reference hit is within round-off of an edge, or of the range ends,
    # may go either way in float32; everything else must agree exactly.
    dn = d / np.linalg.norm(d, axis=1, keepdims=True)
    robust = np.ones(len(o), bool)
    hit_ref = f_ref >= 0
    robust[hit_ref] = edge_margin(o[hit_ref] + dn[hit_ref] * t_ref[hit_ref, None], v, f, f_ref[hit_ref]) > 1e-4
    tmax_b = np.broadcast_to(tmax, t_ref.shape)
    with np.errstate(invalid="ignore"):
        near_end = np.abs(t_ref - tmax_b) < 1e-4 * size
    robust &= ~near_end
    assert robust.mean() > 0.9
    np.testing.assert_array_equal(got.face[robust] >= 0, hit_ref[robust])
    both = robust & hit_ref
    np.testing.assert_allclose(got.t[both], t_ref[both], rtol=rtol, atol=rtol * size)
    # A different face is fine only at the same distance (coplanar duplicates).
    same_t = np.isclose(got.t[both], t_ref[both], rtol=rtol, atol=rtol * size)
    assert same_t.all()
    assert np.isinf(got.t[~got.hit]).all() and (got.face[~got.hit] == -1).all()
    assert (got.bary[~got.hit] == 0).all()  # callers blend by them without masking misses
    return got, t_ref, f_ref


@pytest.fixture
def rng():
    return np.random.default_rng(7)


def test_random_soup_matches_brute_force(rng):
    v, f = random_soup(rng)
    o, d = random_rays(rng, 3000)
    scene = RayScene(v, f)
    got, t_ref, f_ref = assert_matches_brute(scene, v, f, o, d)
    assert 0.2 < got.hit.mean() < 0.95  # the test sees both hits and misses
    hit = got.hit
    # Normals are unit and belong to the reported face; barycentrics reproduce the hit point.
    np.testing.assert_allclose(np.linalg.norm(got.normal[hit], axis=1), 1.0, rtol=1e-12)
    tri = v[f[got.face[hit]]]
    ref_n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    np.testing.assert_allclose(got.normal[hit], ref_n / np.linalg.norm(ref_n, axis=1, keepdims=True), atol=1e-9)
    u, w = got.bary[hit, 0], got.bary[hit, 1]
    p_bary = (1 - u - w)[:, None] * tri[:, 0] + u[:, None] * tri[:, 1] + w[:, None] * tri[:, 2]
    # barycentrics come from Embree in float32: good to a few float32 ulps of the scene size
    np.testing.assert_allclose(p_bary, got.points(o, d)[hit], atol=1e-5)


def test_max_and_min_distance_per_ray(rng):
    v, f = random_soup(rng)
    o, d = random_rays(rng, 2000)
    tmax = rng.uniform(0.0, 2.0, len(o))
    tmin = rng.uniform(0.0, 0.5, len(o))
    scene = RayScene(v, f)
    assert_matches_brute(scene, v, f, o, d, tmin=tmin, tmax=tmax)
    occ = scene.occluded(o, d, max_dist=tmax, min_dist=tmin)
    _, f_ref = moller_trumbore(o, d, v, f, tmin, tmax)
    got = scene.intersect(o, d, max_dist=tmax, min_dist=tmin)
    np.testing.assert_array_equal(occ, got.hit)
    assert (occ == (f_ref >= 0)).mean() > 0.99


def test_threads_give_identical_hits(rng, monkeypatch):
    v, f = random_soup(rng, n_tri=2000)
    o, d = random_rays(rng, 100_000)
    monkeypatch.setattr(embree, "MIN_RAYS_PER_CHUNK", 1000)
    one = RayScene(v, f, threads=1).intersect(o, d)
    two = RayScene(v, f, threads=2).intersect(o, d)
    np.testing.assert_array_equal(one.face, two.face)
    np.testing.assert_array_equal(one.t, two.t)


def test_occlusion_in_chunks_keeps_each_rays_own_range(rng, monkeypatch):
    """Each worker shifts its own rays' origins by their min_dist: rays in many chunks, some of
    them with an empty range, answer as the brute-force search over each ray's own range."""
    v, f = random_soup(rng)
    o, d = random_rays(rng, 6000)
    tmin = rng.uniform(0.0, 0.5, len(o))
    tmax = rng.uniform(0.0, 2.0, len(o))  # about a tenth below tmin: nothing can be met there
    monkeypatch.setattr(embree, "MIN_RAYS_PER_CHUNK", 500)
    occ = RayScene(v, f, threads=2).occluded(o, d, max_dist=tmax, min_dist=tmin)
    _, f_ref = moller_trumbore(o, d, v, f, tmin, tmax)
    assert not occ[tmax < tmin].any()
    assert 0.1 < occ.mean() < 0.9  # both answers are seen
    # float32 tracing may differ from float64 on a ray grazing an edge or its range's end
    assert (occ == (f_ref >= 0)).mean() > 0.99


def test_closed_mesh_from_inside_always_hits():
    sphere = trimesh.creation.icosphere(subdivisions=3)
    n = 5000
    d = np.random.default_rng(1).normal(size=(n, 3))
    got = RayScene(sphere.vertices, sphere.faces).intersect(np.zeros((n, 3)), d)
    assert got.hit.all()  # watertight: no ray escapes between triangles
    # every hit is on the outward-facing side: normal and direction agree
    assert (np.einsum("ij,ij->i", got.normal, d) > 0).all()
    r = np.linalg.norm(got.points(np.zeros((n, 3)), d), axis=1)
    assert r.max() <= 1.0 + 1e-9 and r.min() > 0.98


def test_grazing_rays_are_consistent():
    # A ray in the plane of a triangle: Embree may report either; a reported hit must be real.
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [0, 1, 1]], float)
    f = np.array([[0, 1, 2], [3, 4, 5]])
    o = np.array([[-1, 0.2, 0.0], [-1, 0.2, 1e-9], [-1, 0.2, 0.5]])
    d = np.array([[1, 0, 0], [1, 0, 0], [1, 0, 0]], float)
    got = RayScene(v, f).intersect(o, d)
    assert not got.hit[2]  # between the two planes: nothing
    for i in np.flatnonzero(got.hit):
        p = got.points(o, d)[i]
        assert edge_margin(p[None], v, f, got.face[i:i + 1])[0] > -1e-6
        assert abs(p[2] - v[f[got.face[i]], 2].mean()) < 1e-6


def test_origin_on_surface():
    sheet_a = np.array([[-1, -1, 0], [1, -1, 0], [0, 1, 0]], float)
    sheet_b = sheet_a + [0, 0, 0.5]
    v = np.vstack([sheet_a, sheet_b])
    f = np.array([[0, 1, 2], [3, 4, 5]])
    o = np.array([[0, 0, 0.0], [0, 0, 0.0]])
    d = np.array([[0, 0, 1.0], [0, 0, -1.0]])
    scene = RayScene(v, f)
    # Leaving the surface with a small min_dist: the next sheet, exactly.
    got = scene.intersect(o, d, min_dist=1e-6)
    assert got.face[0] == 1 and got.t[0] == pytest.approx(0.5, abs=1e-12)
    assert not got.hit[1]
    # Without min_dist the surface the origin lies on counts, at distance 0.
    got0 = scene.intersect(o[:1], d[:1])
    assert got0.face[0] in (0, 1)
    if got0.face[0] == 0:
        assert got0.t[0] == pytest.approx(0.0, abs=1e-6)


def test_degenerate_and_duplicate_triangles(rng):
    v, f = random_soup(rng, n_tri=200)
    # zero-area triangles (repeated vertex, collinear vertices) and exact duplicates
    extra_v = np.array([[0, 0, 0], [0, 0, 0], [1, 1, 1], [0, 0, 0], [1, 1, 1], [2, 2, 2]], float)
    v2 = np.vstack([v, extra_v])
    k = len(v)
    f2 = np.vstack([f, [[k, k + 1, k + 2], [k + 3, k + 4, k + 5]], f[:50]])
    o, d = random_rays(rng, 2000)
    got, _, _ = assert_matches_brute(RayScene(v2, f2), v2, f2, o, d)
    assert not np.isin(got.face, [len(f), len(f) + 1]).any()


def test_empty_scene():
    scene = RayScene(np.zeros((0, 3)), np.zeros((0, 3), int))
    got = scene.intersect(np.zeros((4, 3)), np.ones((4, 3)))
    assert not got.hit.any() and np.isinf(got.t).all()
    assert not scene.occluded(np.zeros((4, 3)), np.ones((4, 3))).any()
    none = scene.intersect(np.zeros((0, 3)), np.zeros((0, 3)))
    assert none.t.shape == (0,) and none.normal.shape == (0, 3)


@pytest.mark.parametrize("scale,offset", [(1e-3, 0.0), (1e3, 0.0), (1.0, 1e4)])
def test_tiny_huge_and_far_scenes(rng, scale, offset):
    v, f = random_soup(rng, scale=scale, offset=offset)
    o, d = random_rays(rng, 2000, scale=scale, offset=offset)
    assert_matches_brute(RayScene(v, f), v, f, o, d, rtol=1e-5)


def test_update_moves_the_scene(rng):
    v, f = random_soup(rng)
    scene = RayScene(v, f)
    o, d = random_rays(rng, 1000)
    v_new = v + rng.normal(scale=0.05, size=v.shape)
    scene.update(v_new)
    assert_matches_brute(scene, v_new, f, o, d)
    with pytest.raises(ValueError, match="vertices"):
        scene.update(v_new[:-1])


@pytest.mark.parametrize("quality", ["low", "medium", "high"])
def test_every_build_quality_hits_what_brute_force_hits(rng, quality):
    """How well Embree builds the BVH changes how fast it traces, never what it hits: a scene
    built at each quality, moved in place, and a part of it, answer as Möller–Trumbore."""
    v, f = random_soup(rng, n_tri=600)
    o, d = random_rays(rng, 2000)
    scene = RayScene(v, f, quality=quality)
    assert embree_direct.available(embree.new_scene)  # the wheel CI installs
    assert scene._engine.mesh.quality == quality  # asked of Embree, not dropped on the way
    assert_matches_brute(scene, v, f, o, d)
    v_new = v + rng.normal(scale=0.1, size=v.shape)
    scene.update(v_new)
    assert_matches_brute(scene, v_new, f, o, d, rtol=1e-5)
    part = scene.part([(100, 400)])
    assert part.quality == quality
    got = part.intersect(o, d)
    t_ref, f_ref = moller_trumbore(o, d, v_new, f[100:400], 0.0, np.inf)
    both = got.hit & (f_ref >= 0)
    assert (got.hit == (f_ref >= 0)).mean() > 0.99 and both.mean() > 0.1
    np.testing.assert_allclose(got.t[both], t_ref[both], rtol=1e-5)
    with pytest.raises(ValueError, match="quality"):
        RayScene(v, f, quality="best")


@pytest.mark.parametrize("stretch", [0.05, 0.5])
def test_updated_scene_answers_for_the_moved_triangles(rng, stretch):
    """Updated in place (shared buffers) it must answer as brute force on the new positions,
    small moves and triangles stretched far out of their old boxes alike."""
    v, f = random_soup(rng)
    scene = RayScene(v, f)
    assert embree_direct.available(embree.new_scene)  # the wheel CI installs
    o, d = random_rays(rng, 2000)
    engine = scene._engine
    for _ in range(3):
        v_new = v + rng.normal(scale=stretch, size=v.shape)
        scene.update(v_new)
        assert scene._engine is engine  # written in place, not made anew
        assert_matches_brute(scene, v_new, f, o, d, rtol=1e-5)
    # moved far off: built again about a new centre, still exact
    scene.update(v_new + 1e4)
    assert_matches_brute(scene, v_new + 1e4, f, o + 1e4, d, rtol=1e-5)


def test_embreex_constructor_gives_the_same_hits(rng, monkeypatch):
    """The copy-free geometry and embreex's own vertex-by-vertex constructor agree."""
    v, f = random_soup(rng)
    o, d = random_rays(rng, 2000)
    direct = RayScene(v, f).intersect(o, d)
    monkeypatch.setattr(embree_direct, "_state", "off")
    copied = RayScene(v, f).intersect(o, d)
    np.testing.assert_array_equal(direct.face, copied.face)
    np.testing.assert_allclose(direct.t[direct.hit], copied.t[copied.hit], rtol=1e-12)


@pytest.mark.parametrize(
    "vertices,faces,match",
    [
        (np.full((3, 3), np.nan), [[0, 1, 2]], "vertices contains NaN"),
        (np.zeros((3, 2)), [[0, 1, 2]], r"vertices must have shape \(n, 3\)"),
        (np.zeros((3, 3)), [[0, 1, 3]], "faces index vertices"),
        (np.zeros((3, 3)), [[0, 1]], r"faces must have shape \(m, 3\)"),
        (np.zeros((3, 3)), [[0, 1, -1]], "faces index vertices"),
    ],
)
def test_bad_scene_input(vertices, faces, match):
    with pytest.raises(ValueError, match=match):
        RayScene(vertices, faces)


def test_bad_ray_input():
    scene = RayScene(np.eye(3), [[0, 1, 2]])
    with pytest.raises(ValueError, match="origins contains NaN"):
        scene.intersect([[np.nan, 0, 0]], [[1, 0, 0]])
    with pytest.raises(ValueError, match="zero-length"):
        scene.intersect([[0, 0, 0]], [[0, 0, 0]])
    with pytest.raises(ValueError, match="same shape"):
        scene.intersect(np.zeros((2, 3)), np.ones((3, 3)))
    with pytest.raises(ValueError, match="max_dist contains NaN"):
        scene.intersect([[0, 0, 0]], [[1, 0, 0]], max_dist=np.nan)


def test_numpy_fallback_gives_the_same_hits(rng, monkeypatch):
    v, f = random_soup(rng, n_tri=100)
    o, d = random_rays(rng, 500)
    embree_hits = RayScene(v, f).intersect(o, d, max_dist=2.0)
    monkeypatch.setattr(embree, "HAVE_EMBREE", False)
    monkeypatch.setattr(numpy_backend, "warned", False)
    with pytest.warns(RuntimeWarning, match="embreex is not installed"):
        fallback_scene = RayScene(v, f)
    assert fallback_scene.backend == "numpy"
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # one warning per process, not per scene
        RayScene(v, f)
    numpy_hits = fallback_scene.intersect(o, d, max_dist=2.0)
    t_ref, f_ref = moller_trumbore(o, d, v, f, 0.0, 2.0)
    agree = (numpy_hits.face >= 0) == (embree_hits.face >= 0)
    assert agree.mean() > 0.995
    both = agree & embree_hits.hit
    np.testing.assert_allclose(numpy_hits.t[both], embree_hits.t[both], rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize("backend", ["embree", "numpy"])
def test_scaled_rays_measure_in_their_directions_length(rng, monkeypatch, backend):
    """With ``scaled``, a ray's distances are in units of its direction's length (0..1 along an
    edge given as start and vector): the hits of brute force along the unit direction, with
    the range and the answer's t multiplied by that length."""
    v, f = random_soup(rng)
    o, d = random_rays(rng, 2000)
    length = np.linalg.norm(d, axis=1) * 10.0 ** rng.uniform(-1, 1, len(d))
    d = d / np.linalg.norm(d, axis=1, keepdims=True) * length[:, None]
    tmin, tmax = rng.uniform(0.0, 0.5, len(o)), rng.uniform(0.5, 3.0, len(o))
    if backend == "numpy":
        monkeypatch.setattr(embree, "HAVE_EMBREE", False)
        monkeypatch.setattr(numpy_backend, "warned", True)
    scene = RayScene(v, f)
    assert scene.backend == backend
    got = scene.intersect(o, d, max_dist=tmax / length, min_dist=tmin / length, scaled=True)
    unit = scene.intersect(o, d, max_dist=tmax, min_dist=tmin)
    assert_matches_brute(scene, v, f, o, d, tmin=tmin, tmax=tmax)
    np.testing.assert_array_equal(got.face, unit.face)
    np.testing.assert_allclose(got.t[got.hit] * length[got.hit], unit.t[got.hit], rtol=1e-9)
    np.testing.assert_allclose(got.bary, unit.bary, atol=1e-5)  # Embree's float32 barycentrics


@pytest.mark.parametrize("direct", ["on", "off", "numpy"])
def test_parts_answer_as_brute_force_over_their_faces_and_name_the_whole_scenes_faces(rng, monkeypatch, direct):
    """A part over some face ranges hits what Möller–Trumbore finds among those faces alone and
    names them by their ids in the whole scene; with Embree instancing (direct on) overlapping
    parts build each range once, and without it (off, or no Embree at all) the part is a scene
    of its own."""
    if direct == "off":
        monkeypatch.setattr(embree_direct, "_state", "off")
    if direct == "numpy":
        monkeypatch.setattr(embree, "HAVE_EMBREE", False)
        monkeypatch.setattr(numpy_backend, "warned", True)
    v, f = random_soup(rng, n_tri=900)
    o, d = random_rays(rng, 2000)
    scene = RayScene(v, f)
    tmax = rng.uniform(0.5, 3.0, len(o))
    for ranges in ([(300, 900)], [(600, 900)], [(0, 300), (600, 900)]):
        part = scene.part(ranges)
        keep = np.concatenate([np.arange(a, b) for a, b in ranges])
        got = part.intersect(o, d, max_dist=tmax)
        t_ref, f_ref = moller_trumbore(o, d, v, f[keep], 0.0, tmax)
        agree = got.hit == (f_ref >= 0)
        assert agree.mean() > 0.99 and got.hit.mean() > 0.2
        both = agree & got.hit
        np.testing.assert_allclose(got.t[both], t_ref[both], rtol=1e-9, atol=1e-9)
        same = both & np.isclose(got.t, t_ref, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(got.face[same], keep[f_ref[same]])  # ids of the whole scene
        assert np.isin(got.face[got.hit], keep).all()
        np.testing.assert_array_equal(part.occluded(o, d, max_dist=tmax), got.hit)
        tri = v[f[got.face[both]]]
        np.testing.assert_allclose(got.normal[both], _unit(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])),
                                   atol=1e-9)
    if direct == "on":
        assert len(scene._groups) == 3  # (300, 900), (600, 900), (0, 300): none built twice
    assert not scene.part([]).intersect(o, d).hit.any()
    with pytest.raises(ValueError, match="face ranges"):
        scene.part([(0, 901)])
    scene.update(v * 1.01)
    with pytest.raises(RuntimeError, match="make the part again"):
        part.intersect(o, d)
    with pytest.raises(RuntimeError, match="cannot move"):
        part.update(v)


@pytest.mark.parametrize("direct", ["on", "off", "numpy"])
def test_a_union_is_occluded_where_brute_force_meets_any_of_its_scenes(rng, monkeypatch, direct):
    """Scenes far apart (each built about its own centre) and a part of one: the union's
    occlusion, with per-ray ranges, is Möller–Trumbore over all their triangles together (with
    instancing, without, and without Embree); rays are also scaled edges (0..1 of their
    length); a member moved since raises."""
    if direct == "off":
        monkeypatch.setattr(embree_direct, "_state", "off")
    if direct == "numpy":
        monkeypatch.setattr(embree, "HAVE_EMBREE", False)
        monkeypatch.setattr(numpy_backend, "warned", True)
    soups = [random_soup(rng, n_tri=300, offset=off) for off in (0.0, 2.5, -40.0)]
    scenes = [RayScene(v, f) for v, f in soups]
    whole = RayScene(*random_soup(rng, n_tri=400, offset=1.0))
    members = [*scenes, whole.part([(100, 300)])]
    v_all = np.vstack([v for v, _ in soups] + [whole.vertices])
    offsets = np.cumsum([0] + [len(v) for v, _ in soups])
    f_all = np.vstack([f + offsets[i] for i, (_, f) in enumerate(soups)] + [whole.faces[100:300] + offsets[-1]])
    union = SceneUnion(members)
    o, d = random_rays(rng, 3000)
    o[::3] -= [40.0, 40.0, 40.0]  # a third start beside the far scene
    tmin, tmax = rng.uniform(0.0, 0.5, len(o)), rng.uniform(0.5, 6.0, len(o))
    _, f_ref = moller_trumbore(o, d, v_all, f_all, tmin, tmax)
    got = union.occluded(o, d, max_dist=tmax, min_dist=tmin)
    # float32 tracing may differ from float64 on rays through an edge or an end point: a few
    assert (got == (f_ref >= 0)).mean() > 0.998 and 0.1 < got.mean() < 0.9 and got[::3].any()
    unit = d / np.linalg.norm(d, axis=1, keepdims=True)
    scaled = union.occluded(o, unit * tmax[:, None], max_dist=1.0, min_dist=tmin / tmax, scaled=True)
    assert (scaled == (f_ref >= 0)).mean() > 0.998
    assert not SceneUnion([]).occluded(o, d).any()
    scenes[1].update(soups[1][0] * 1.01)
    with pytest.raises(RuntimeError, match="make the union again"):
        union.occluded(o, d)


def _unit(n):
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def test_a_part_is_watertight_along_the_edges_and_corners_its_triangles_share():
    """Rays straight down through every vertex and edge midpoint of a grid's inside all hit a
    part holding the grid: none slips between the triangles that share that edge or corner."""
    n = 11
    s = np.linspace(-0.5, 0.5, n)
    x, y = np.meshgrid(s, s)
    grid = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    i, j = np.meshgrid(np.arange(n - 1), np.arange(n - 1), indexing="ij")
    a = (i * n + j).ravel()
    f = np.concatenate([np.stack([a, a + 1, a + n + 1], -1), np.stack([a, a + n + 1, a + n], -1)])
    other = grid + [0.0, 0.0, 0.03]  # another object of the scene, above it
    scene = RayScene(np.vstack([other, grid]), np.vstack([f, f + len(grid)]))
    part = scene.part([(len(f), 2 * len(f))])
    inner = np.linspace(-0.4, 0.4, 2 * (n - 3) + 1)  # vertices and the midpoints between them
    gx, gy = np.meshgrid(inner, inner)
    o = np.column_stack([gx.ravel(), gy.ravel(), np.full(gx.size, 0.01)])
    d = np.tile([0.0, 0.0, -1.0], (len(o), 1))
    assert part.occluded(o, d, max_dist=0.02).all()
    hits = part.intersect(o, d, max_dist=0.02)
    assert (hits.face >= len(f)).all()
    np.testing.assert_allclose(hits.t, 0.01, atol=1e-9)


def test_a_scene_and_its_parts_are_freed_with_their_last_reference():
    """Without the cycle collector: a scene that refers to itself keeps its Embree memory until
    a collection runs, and a resolve builds dozens of them (memory grew ~35 MB a resolve)."""
    import gc
    import weakref

    sphere = trimesh.creation.icosphere(subdivisions=2)
    gc.disable()
    try:
        scene = RayScene(sphere.vertices, sphere.faces)
        part = scene.part([(0, 40), (100, 160)])
        assert part.intersect([[0.0, 0.0, 3.0]], [[0.0, 0.0, -1.0]]).hit.shape == (1,)
        gone = [weakref.ref(scene), weakref.ref(part)]
        del scene, part
        assert [ref() for ref in gone] == [None, None]
    finally:
        gc.enable()
