"""resolve_layers on cases with known answers, extreme inputs and bad input."""

import numpy as np
import pytest
import trimesh

from core.layering import resolve_layers
from core.layering.metrics import crossings, unique_edges
from sample_scenes.shapes import tube
from tests.core.brute import brute_crossings
from tests.core.layered_cases import body_tube, capped_cylinder, mesh, noisy_sleeves, sheet, slab_body


def radial(v):
    return np.linalg.norm(v[:, :2], axis=1)


def max_stretch(v0, v1, f):
    e = unique_edges(f)
    return float((np.linalg.norm(v1[e[:, 0]] - v1[e[:, 1]], axis=1) /
                  np.linalg.norm(v0[e[:, 0]] - v0[e[:, 1]], axis=1)).max())


def test_concentric_noisy_cylinders_stop_crossing():
    body = body_tube()
    shirt, jacket = noisy_sleeves(n=40)
    assert brute_crossings(shirt.vertices, shirt.faces, jacket.vertices, jacket.faces) > 100
    res = resolve_layers(body, [shirt, jacket])
    s, j = res.garments
    assert brute_crossings(s.vertices, s.faces, j.vertices, j.faces) == 0
    # the outer layer only moves outward, where it lay closer to the body than the layers under it
    # need (lifted off the body, by less than a millimetre); the inner one only moves inward,
    # never into the body
    assert (radial(j.vertices) >= radial(jacket.vertices) - 1e-12).all()
    assert np.linalg.norm(res.moved[1], axis=1).max() < 1e-3
    assert (radial(s.vertices) <= radial(shirt.vertices) + 1e-12).all()
    assert radial(s.vertices).min() > 0.15
    assert np.linalg.norm(res.moved[0], axis=1).max() < 0.05


def test_z_fighting_sheets_move_exactly_the_offset():
    body = slab_body()
    v, f = sheet(n=30, z=0.01)
    d = 0.002
    res = resolve_layers(body, [mesh(v, f), mesh(v, f)], offset=d, probe_distance=0.05)
    inner = res.garments[0].vertices
    inside = (np.abs(v[:, :2]) < 0.45).all(1)  # away from the sheet's rim
    np.testing.assert_allclose(inner[inside, 2], 0.01 - d, atol=1e-9)
    np.testing.assert_allclose(inner[inside, :2], v[inside, :2], atol=1e-12)
    assert not res.removed_faces[0].any()


def test_sleeve_next_to_a_torso_is_not_pushed_into_it():
    """Fig. 4.5: a probe must not reach the torso's outer garment through the arm."""
    torso = capped_cylinder(0.15, 0.6, n=48)
    arm = capped_cylinder(0.04, 0.6, center=(0.22, 0.0), n=32)
    body = trimesh.util.concatenate([torso, arm])
    body_seg = np.r_[np.zeros(len(torso.vertices), int), np.ones(len(arm.vertices), int)]
    from sample_scenes.shapes import tube

    sv, sf = tube(0.05, -0.25, 0.25, grid=(32, 20))
    sleeve = mesh(sv + [0.22, 0, 0], sf)  # layer 1, on the arm
    jv, jf = tube(0.165, -0.25, 0.25, grid=(64, 20))
    jacket = mesh(jv, jf)  # layer 2, on the torso, 1.5 cm from the sleeve
    for segs in (None, body_seg):
        res = resolve_layers(body, [sleeve, jacket], body_segments=segs)
        assert not res.moved[0].any(), "the sleeve moved though nothing covers it"
        # the arm does not touch the torso: no part border to look across
        assert res.stats["vertices_on_part_borders"] == 0
    # a single probe distance as long as the torso radius would reach through the arm
    res = resolve_layers(body, [sleeve, jacket], probe_distance=0.15)
    assert res.moved[0].any()
    # segment_links=True (the panel's Whole Body) makes the separate pieces one body again
    whole = resolve_layers(body, [sleeve, jacket], probe_distance=0.15, body_segments=np.zeros_like(body_seg))
    linked = resolve_layers(body, [sleeve, jacket], probe_distance=0.15, segment_links=True)
    parted = resolve_layers(body, [sleeve, jacket], probe_distance=0.15, body_segments=body_seg)
    np.testing.assert_array_equal(linked.moved[0], whole.moved[0])
    moving = [int(np.abs(r.moved[0]).sum(1).astype(bool).sum()) for r in (parted, linked)]
    assert moving[0] < moving[1]


def test_fold_with_flipping_normals_goes_behind_a_flat_layer():
    """Fig. 4.6: an overhanging fold whose geometric normals flip; body normals still guide it."""
    body = slab_body()
    s = np.linspace(-0.5, 0.5, 200)
    # parametric cross-section with an overhang: x doubles back around s = 0
    x = s - 0.06 * np.sin(np.pi * np.clip(s / 0.1, -1, 1)) * (np.abs(s) < 0.1)
    z = 0.012 + 0.01 * np.exp(-(s / 0.05) ** 2)
    y = np.linspace(-0.5, 0.5, 30)
    xx, yy = np.meshgrid(x, y)
    zz = np.broadcast_to(z, xx.shape)
    v = np.column_stack([xx.ravel(), yy.ravel(), zz.ravel()])
    n = len(s)
    i, j = np.meshgrid(np.arange(len(y) - 1), np.arange(n - 1), indexing="ij")
    a = i * n + j
    f = np.concatenate([np.stack([a, a + 1, a + n + 1], -1).reshape(-1, 3),
                        np.stack([a, a + n + 1, a + n], -1).reshape(-1, 3)])
    fold = mesh(v, f)
    geo = fold.face_normals[:, 2]
    assert (geo < 0).any() and (geo > 0).any()  # the fold really flips its normals
    top_v, top_f = sheet(size=1.1, n=44, z=0.015)  # covers the fold, rims apart
    res = resolve_layers(body, [fold, mesh(top_v, top_f)], offset=0.001, probe_distance=0.05)
    low = res.garments[0]
    assert low.vertices[:, 2].max() <= 0.015 - 0.001 + 1e-9
    assert brute_crossings(low.vertices, low.faces, top_v, top_f) == 0


def test_hem_boundary_pass_tucks_the_lower_layer_in_smoothly():
    """Fig. 4.10: a shirt 5 mm outside a jacket that ends at z = 0.2."""
    from sample_scenes.shapes import tube

    body = body_tube()
    shirt = mesh(*tube(0.175, 0.0, 0.6, grid=(40, 40)))
    jacket = mesh(*tube(0.17, 0.2, 0.6, grid=(40, 27)))
    plain = resolve_layers(body, [shirt, jacket], boundary_pass=False)
    tucked = resolve_layers(body, [shirt, jacket])
    for res in (plain, tucked):
        s = res.garments[0]
        assert brute_crossings(s.vertices, s.faces, jacket.vertices, jacket.faces) == 0
    stretch_plain = max_stretch(shirt.vertices, plain.garments[0].vertices, shirt.faces)
    stretch_tucked = max_stretch(shirt.vertices, tucked.garments[0].vertices, shirt.faces)
    assert stretch_tucked < stretch_plain
    # below the hem the tucked shirt eases in over several rings instead of one step
    below = (shirt.vertices[:, 2] < 0.2) & (shirt.vertices[:, 2] > 0.1)
    assert np.linalg.norm(tucked.moved[0][below], axis=1).max() > 0.002
    assert tucked.stats["vertices_moved_boundary"] > 0


def test_a_lower_layer_is_tucked_under_a_hem_where_the_hem_ends_up():
    """A shirt, a vest ending at z = 0.2 and a jacket inside both: the jacket pushes the vest in,
    so the shirt must be tucked under the vest's hem where the vest goes, not where it was."""
    from sample_scenes.shapes import tube

    body = body_tube()
    shirt = mesh(*tube(0.18, 0.0, 0.6, grid=(40, 40)))
    vest = mesh(*tube(0.175, 0.2, 0.6, grid=(40, 27)))
    jacket = mesh(*tube(0.17, 0.0, 0.6, grid=(40, 40)))
    res = resolve_layers(body, [shirt, vest, jacket])
    d = res.stats["offset"]
    radius = [np.hypot(*g.vertices[:, :2].T) for g in res.garments]
    hem = np.isclose(vest.vertices[:, 2], 0.2)
    near_hem = np.abs(shirt.vertices[:, 2] - 0.2) < 0.016  # the shirt's rings either side of it
    assert radius[1][hem].max() < 0.17  # the vest went behind the jacket
    assert radius[0][near_hem].max() < radius[1][hem].min() - 0.5 * d
    again = resolve_layers(body, res.garments)
    assert again.stats["vertices_moved_boundary"] == 0


def test_a_hem_the_body_holds_a_layer_in_front_of_tucks_nothing_around_it():
    """A shirt squeezed against the body for a band round a jacket's hem that presses into it:
    the shirt cannot go under that hem, so its looser rings beyond the band stay where they are,
    and resolving the result again moves nothing (a spread from the hem dug them in further on
    every resolve)."""
    from sample_scenes.shapes import tube

    def taper(v, tight, loose, band):
        ease = np.clip((np.abs(v[:, 2] - 0.2) - band) / 0.03, 0, 1)
        r = tight + (loose - tight) * ease
        return np.column_stack([v[:, :2] * (r / np.hypot(v[:, 0], v[:, 1]))[:, None], v[:, 2]])

    body = body_tube()
    sv, sf = tube(0.165, 0.0, 0.6, grid=(40, 40))  # rings 15.4 mm apart, one at z = 0.2
    jv, jf = tube(0.17, 0.2, 0.6, grid=(40, 27))
    shirt, jacket = mesh(taper(sv, 0.1515, 0.165, 0.02), sf), mesh(taper(jv, 0.151, 0.17, 0.0), jf)
    res = resolve_layers(body, [shirt, jacket], remove_hidden=False)
    assert res.stats["rays_boundary"] > 0 and res.stats["vertices_held_by_body"] > 0
    assert res.stats["vertices_moved_boundary"] == 0
    again = resolve_layers(body, [mesh(g.vertices, g.faces) for g in res.garments], remove_hidden=False)
    # (within micrometres: the floor the first resolve held them at was found from a lower bound on
    # the distance, the second knows it exactly)
    assert np.linalg.norm(again.moved[0], axis=1).max() < 1e-5


def test_a_correspondence_from_another_frame_never_pushes_cloth_into_the_body():
    """Cloth frames reuse the first frame's correspondence while the cloth slides over its
    collider: the body points it names are elsewhere now, and their distance bounds nothing.
    A sheet 1 cm over a box, a higher sheet that dips 5 mm into the box: the lower sheet goes
    as far down as the box lets it, not into it."""
    box = trimesh.creation.box(extents=(1.0, 1.0, 0.4))
    body = mesh(box.vertices + [0, 0, 0.2], box.faces)
    v, f = sheet(size=1.4, n=30, z=0.41)
    low, high = mesh(v, f), mesh(v * [1, 1, 0] + [0, 0, 0.395], f)
    slid = [mesh(g.vertices + [0.3, 0, 0], f) for g in (low, high)]
    then = resolve_layers(body, slid, boundary_pass=False, push_behind=False, remove_hidden=False)
    res = resolve_layers(body, [low, high], correspondence=then.correspondence, remove_hidden=False)
    g = res.garments[0]
    assert brute_crossings(body.vertices, body.faces, low.vertices, low.faces) == 0
    assert brute_crossings(body.vertices, body.faces, g.vertices, g.faces) == 0
    over_box = (np.abs(g.vertices[:, :2]) < 0.5).all(1)
    assert g.vertices[over_box, 2].min() > 0.4
    assert np.linalg.norm(res.moved[0], axis=1).max() > 0.004  # it did go down


def test_cloth_between_held_vertices_does_not_cut_through_a_ridge_of_the_body():
    """A coarse twelve-sided sleeve round a square prism, pushed behind a finer one: each vertex
    stays clear of the prism, but the flat triangles between them would cut through its ridges
    (76 body edges through the sleeve); the moves that do so are taken back."""
    from sample_scenes.shapes import tube

    box = trimesh.creation.box(extents=(0.3, 0.3, 0.6))
    body = mesh(box.vertices, box.faces)
    sleeve = mesh(*tube(0.24, -0.25, 0.25, grid=(12, 10)))
    over = mesh(*tube(0.216, -0.22, 0.22, grid=(96, 20)))
    assert brute_crossings(body.vertices, body.faces, sleeve.vertices, sleeve.faces) == 0
    res = resolve_layers(body, [sleeve, over], remove_hidden=False)
    g = res.garments[0]
    assert brute_crossings(body.vertices, body.faces, g.vertices, g.faces) == 0
    assert res.stats["vertices_kept_out_of_body"] > 0
    assert radial(g.vertices).min() < 0.216  # the rest of the sleeve still went behind
    unguarded = resolve_layers(body, [sleeve, over], remove_hidden=False, body_guard=False).garments[0]
    assert brute_crossings(body.vertices, body.faces, unguarded.vertices, unguarded.faces) > 0


def test_already_correct_garments_are_left_alone():
    from sample_scenes.shapes import tube

    body = body_tube()
    shirt = mesh(*tube(0.16, 0.05, 0.55, grid=(64, 32)))
    jacket = mesh(*tube(0.175, 0.1, 0.55, grid=(64, 32)))
    res = resolve_layers(body, [shirt, jacket])
    assert not any(m.any() for m in res.moved)
    assert not any(r.any() for r in res.removed_faces)
    np.testing.assert_array_equal(res.garments[0].faces, shirt.faces)


def test_inputs_are_never_modified():
    body = body_tube()
    garments = noisy_sleeves()
    before = [g.vertices.copy() for g in garments]
    resolve_layers(body, garments)
    for g, v in zip(garments, before, strict=True):
        np.testing.assert_array_equal(g.vertices, v)


def test_flipped_garment_winding_gives_the_same_result():
    body = body_tube()
    garments = noisy_sleeves()
    flipped = [mesh(g.vertices, g.faces[:, ::-1]) for g in garments]
    a = resolve_layers(body, garments)
    b = resolve_layers(body, flipped)
    np.testing.assert_allclose(a.moved[0], b.moved[0], atol=1e-12)


@pytest.mark.parametrize("scale", [1e-3, 1e3])
def test_millimetre_and_kilometre_scales(scale):
    body = body_tube()
    garments = noisy_sleeves()
    ref = resolve_layers(body, garments)
    scaled = resolve_layers(mesh(body.vertices * scale, body.faces),
                            [mesh(g.vertices * scale, g.faces) for g in garments])
    np.testing.assert_allclose(scaled.moved[0], ref.moved[0] * scale, rtol=1e-6, atol=1e-9 * scale)
    s, j = scaled.garments
    assert brute_crossings(s.vertices, s.faces, j.vertices, j.faces) == 0


def test_ten_layers():
    body = body_tube()
    radii = tuple(0.165 + 0.002 * k for k in range(10))
    garments = noisy_sleeves(radii=radii, noise=0.01, z0_step=0.01)
    res = resolve_layers(body, garments)
    out = res.garments
    # core.metrics.crossings is checked against brute force in test_metrics; brute force here
    # would take minutes for 45 pairs
    assert sum(crossings(garments[a].vertices, garments[a].faces, garments[a + 1].vertices, garments[a + 1].faces)
               for a in range(9)) > 0
    for a in range(10):
        for b in range(a + 1, 10):
            assert crossings(out[a].vertices, out[a].faces, out[b].vertices, out[b].faces) == 0, (a, b)


def test_degenerate_duplicate_nonmanifold_and_empty_garments():
    body = body_tube()
    shirt, jacket = noisy_sleeves()
    v = np.vstack([shirt.vertices, shirt.vertices[:3], [[0.3, 0, 0.3]] * 3])  # duplicate + collapsed
    k = len(shirt.vertices)
    extra = [[k, k + 1, k + 2], [k + 3, k + 4, k + 5], [0, 1, k + 3]]
    # a non-manifold fin: a third triangle on an existing edge
    fin = [[shirt.faces[0, 0], shirt.faces[0, 1], k + 3]]
    messy = mesh(v, np.vstack([shirt.faces, extra, fin]))
    empty = mesh(np.zeros((0, 3)), np.zeros((0, 3), int))
    res = resolve_layers(body, [empty, messy, jacket])
    assert len(res.garments[0].faces) == 0 and res.moved[0].shape == (0, 3)
    g = res.garments[1]
    assert np.isfinite(g.vertices).all()
    keep = np.ones(len(messy.faces), bool)
    keep[len(shirt.faces):] = False
    assert brute_crossings(g.vertices, messy.faces[keep & ~res.removed_faces[1]], jacket.vertices, jacket.faces) == 0


def test_garments_far_from_the_body_are_reported_not_moved_wildly():
    body = body_tube()
    # both 5 m off: crossing each other, far from the body
    far = [mesh(g.vertices + [5.0, 0, 0], g.faces) for g in noisy_sleeves()]
    res = resolve_layers(body, far)
    assert res.traced == [True, True]
    assert res.stats["vertices_beyond_probe"] == sum(len(g.vertices) for g in far)
    # reported: the inner layer's points on faces that still crossed and were hidden (the outer
    # layer sends no probe; loose cloth that crosses nothing is no concern)
    on_hidden = np.unique(far[0].faces[res.removed_faces[0]])
    assert res.stats["vertices_far_from_body"] == len(on_hidden) > 0
    apart = [far[0], mesh(far[1].vertices + [0, 0, 1.0], far[1].faces)]  # no longer crossing
    assert resolve_layers(body, apart).stats["vertices_far_from_body"] == 0
    # no move beyond two probe reaches (the hem tuck and the push; a reach: the body's radius,
    # 15 cm, plus d), however odd the normals of the body's far side are here
    assert np.linalg.norm(res.moved[0], axis=1).max() <= 2 * (0.15 + res.stats["offset"]) + 1e-9
    assert not res.moved[1].any()


def test_a_garment_near_no_other_skips_every_stage_and_its_normals_are_found_when_asked():
    body = body_tube()
    shirt, jacket = noisy_sleeves()
    # a sleeve 5 m to the side, and a flat band 3 m above the body
    far = mesh(shirt.vertices + [5.0, 0, 0], shirt.faces)
    band = mesh(jacket.vertices * [1, 1, 0.1] + [0, 0, 3.55], jacket.faces)
    res = resolve_layers(body, [far, shirt, jacket, band])
    assert res.traced == [False, True, True, False] and res.stats["garments_traced"] == 2
    # the two in the middle resolve as they do alone: the room a layer keeps from the body follows
    # its place among the garments that take part, not among four
    alone = resolve_layers(body, [shirt, jacket])
    assert res.stats["vertices_held_by_body"] == alone.stats["vertices_held_by_body"]
    for i in (0, 1):
        np.testing.assert_array_equal(res.moved[i + 1], alone.moved[i])
        np.testing.assert_array_equal(res.removed_faces[i + 1], alone.removed_faces[i])
    for i in (0, 3):
        assert not res.moved[i].any() and not res.removed_faces[i].any()
    normals, corr = res.found()
    assert normals[0] is corr[0] is None and corr[1] is not None and normals[2] is not None
    # found on first use: the nearest body points, against trimesh's own search
    for i, g in ((0, far), (3, band)):
        c = res.correspondence[i]
        want, dist, _ = trimesh.proximity.closest_point(body, g.vertices)
        np.testing.assert_allclose(c.distance, dist, atol=1e-6)
        # the band's points exactly; 5 m off, a point 1 mm along the body is as near to within
        # float32's pick, so the sleeve's distances only
        if i == 3:
            np.testing.assert_allclose(c.points(body.vertices, body.faces), want, atol=1e-9)
        assert res.global_normals[i].shape == g.vertices.shape and len(res.segments[i]) == len(g.vertices)
    # one garment alone has nothing to be layered with: no search, no rays, no move
    one = resolve_layers(body, [jacket])
    assert one.traced == [False] and one.stats["rays_push"] == 0 and not one.moved[0].any()


@pytest.mark.parametrize("scale", [1.0, 1e-3, 1e3])
def test_sleeves_at_other_heights_skip_the_stages_and_change_nothing(monkeypatch, scale):
    import core.layering.garment_prep as prep
    from sample_scenes.shapes import tube

    body = body_tube(height=0.8)
    shirt, jacket = noisy_sleeves()  # crossing each other on z 0.08-0.55
    cuff = mesh(*tube(0.17, 0.62, 0.75, grid=(64, 16)))  # 7 cm above them
    # at millimetre and kilometre scales too
    body, shirt, cuff, jacket = (mesh(m.vertices * scale, m.faces) for m in (body, shirt, cuff, jacket))
    garments = [shirt, cuff, jacket]
    searched = []
    search = prep.nearest_on_surface
    monkeypatch.setattr(prep, "nearest_on_surface",
                        lambda p, *a, **k: searched.append(len(p)) or search(p, *a, **k))
    res = resolve_layers(body, garments)
    # their boxes are within three probe reaches (the body's 15 cm radius), but every move and
    # ray goes across the body, along n', never up or down it: the normals of the body near
    # the cuff say so before its body points are searched
    assert res.traced == [True, False, True] and res.stats["garments_traced"] == 2
    assert res.found()[1][1] is None and searched == [len(shirt.vertices) + len(jacket.vertices)]
    # the cuff changes nothing: the others resolve as they do without it
    without = resolve_layers(body, [shirt, jacket])
    for a, b in zip([res.moved[0], res.moved[2]], without.moved, strict=True):
        np.testing.assert_array_equal(a, b)
    for a, b in zip([res.removed_faces[0], res.removed_faces[2]], without.removed_faces, strict=True):
        np.testing.assert_array_equal(a, b)
    assert not res.moved[1].any() and not res.removed_faces[1].any() and res.moved[0].any()
    monkeypatch.setattr(prep, "near_another", lambda garr, grow: [True] * len(garr))
    every = resolve_layers(body, garments)
    assert every.traced == [True, True, True]
    # and what is found for the cuff when asked is what the search gives it
    np.testing.assert_array_equal(res.global_normals[1], every.global_normals[1])
    np.testing.assert_array_equal(res.correspondence[1].triangle, every.correspondence[1].triangle)


@pytest.mark.parametrize("body_kind", ["capped tube", "box on a floor", "coarse box", "hexagonal tube"])
def test_the_bound_before_the_search_holds_every_normal_the_search_gives(body_kind):
    """Points near sharp edges, caps of long fan triangles and a floor of two triangles:
    v + R n' and v - 3R n' stay in the box _swept_bound gives, for the n' nearest_on_surface finds."""
    import core.layering.garment_prep as prep
    from core.layering.body_facts import body_facts
    from core.layering.correspondence import nearest_on_surface

    rng = np.random.default_rng(3)
    box = trimesh.creation.box(extents=[0.4, 0.3, 0.5])
    if body_kind == "capped tube":
        body = body_tube(n=48)
        targets = [[0.0, 0.0, 0.62], [0.1, 0.0, 0.61], [0.16, 0.0, 0.3]]  # over the fan cap, its rim, the side
    elif body_kind == "box on a floor":
        fine = slab_body(size=0.4, thickness=0.4, subdivisions=3)  # flat faces: normals exactly along the axes
        floor = mesh(np.array([[-3, -3, -0.4], [3, -3, -0.4], [3, 3, -0.4], [-3, 3, -0.4]], float),
                     np.array([[0, 1, 2], [0, 2, 3]]))
        body = trimesh.util.concatenate([fine, floor])
        # above the floor far from the box, where its nearest vertices are the box's: the floor's
        # two triangles are nearer than any triangle around them
        targets = [[1.0, 0.0, -0.37], [0.0, -1.5, -0.35], [0.3, 0.0, -0.3]]
    elif body_kind == "coarse box":
        body = box  # 12 triangles, corner normals 70 degrees apart: a face's middle blends them to its normal
        targets = [[0.22, 0.0, 0.0], [0.0, 0.17, 0.0], [0.0, 0.0, 0.27], [0.21, 0.16, 0.26]]
    else:
        from sample_scenes.shapes import tube

        # six sides: corner normals 60 degrees apart, a side's middle blends two of them to a normal
        # longer along the side's axis than either (cos 30 degrees)
        body = mesh(*tube(0.15, 0.0, 0.6, grid=(6, 4)))
        targets = [[0.0, 0.15, 0.3], [0.0, -0.16, 0.2], [0.14, 0.08, 0.4]]
    facts = body_facts(np.asarray(body.vertices, float), np.asarray(body.faces))
    reach = 0.07
    lo, hi = facts.vertices.min(0), facts.vertices.max(0)
    patches = [np.asarray(t) + rng.normal(scale=0.01, size=(200, 3)) for t in targets]
    # and patches of any size anywhere around the body, up to 5 cm off it
    patches += [rng.uniform(lo - 0.05, hi + 0.05) + rng.normal(scale=rng.uniform(0.005, 0.1), size=(300, 3))
                for _ in range(10)]
    for v in patches:
        dist, near = facts.search.tree.query(v, k=2)
        box_lo, box_hi = prep._swept_bound(v, near, dist[:, 0], facts, reach)
        found = nearest_on_surface(v, facts.vertices, facts.faces, search=facts.search)
        n = found.normals(facts.normals, facts.faces)
        for end in (v + reach * n, v - 3 * reach * n):
            assert (end >= box_lo - 1e-12).all() and (end <= box_hi + 1e-12).all()


@pytest.mark.parametrize(("shells", "gap"), [([0.0, 0.0], 0.002), ([0.004, 0.0], 0.006),  # the lower sheet grows out
                                             ([0.0, 0.01], 0.002)])  # the top's shell meets no layer
def test_an_outward_shell_a_later_modifier_adds_widens_the_gap_by_its_thickness(shells, gap):
    body = slab_body()
    v, f = sheet(n=30, z=0.05)  # clear of the body's floor
    res = resolve_layers(body, [mesh(v, f), mesh(v, f)], offset=0.002, probe_distance=0.1, outward_shells=shells)
    inside = (np.abs(v[:, :2]) < 0.45).all(1)
    np.testing.assert_allclose(res.garments[0].vertices[inside, 2], 0.05 - gap, atol=1e-9)


@pytest.mark.parametrize(
    "make,match",
    [
        (lambda b, g: (None, g), "body is missing"),
        (lambda b, g: (mesh(np.zeros((0, 3)), np.zeros((0, 3), int)), g), "body has no faces"),
        (lambda b, g: (b, g[0]), "list of meshes"),
        (lambda b, g: (b, [mesh(np.full_like(g[0].vertices, np.nan), g[0].faces)]), "NaN"),
        (lambda b, g: (b, [mesh(g[0].vertices, g[0].faces + len(g[0].vertices))]), "outside"),
    ],
)
def test_bad_input_raises_a_clear_error(make, match):
    body, garments = make(body_tube(), noisy_sleeves())
    with pytest.raises(ValueError, match=match):
        resolve_layers(body, garments)


def test_bad_parameters_raise():
    with pytest.raises(ValueError, match="unknown parameter"):
        resolve_layers(body_tube(), noisy_sleeves(), ofset=0.1)
    with pytest.raises(ValueError, match="body_segments"):
        resolve_layers(body_tube(), noisy_sleeves(), body_segments=np.zeros(3, int))
    with pytest.raises(ValueError, match="offset"):
        resolve_layers(body_tube(), noisy_sleeves(), offset=-1.0)
    # a typo or a unit mix-up (1e6 once moved cloth 666 km and reported success); the body is 0.73 across
    with pytest.raises(ValueError, match="offset 1e\\+06 is more than 5% of the body's size"):
        resolve_layers(body_tube(), noisy_sleeves(), offset=1e6)
    resolve_layers(body_tube(), noisy_sleeves(), offset=0.03)  # a thick coat's gap on this body is fine
    with pytest.raises(ValueError, match="probe_distance 5 is longer than the body"):
        resolve_layers(body_tube(), noisy_sleeves(), probe_distance=5.0)
    for shells in ([0.0], [0.0, -0.001], [np.nan, 0.0], [[0.0, 0.0], [0.0, 0.0]]):
        with pytest.raises(ValueError, match="outward_shells"):
            resolve_layers(body_tube(), noisy_sleeves(), outward_shells=shells)
    with pytest.raises(ValueError, match="simulated needs one entry per garment"):
        resolve_layers(body_tube(), noisy_sleeves(), simulated=[True])
    with pytest.raises(ValueError, match="subdivided needs one entry per garment"):
        resolve_layers(body_tube(), noisy_sleeves(), subdivided=[True, False, True])
    for falloff in (0.0, -1.0, np.nan, np.inf):  # NaN used to change the result, 0 to divide by it
        with pytest.raises(ValueError, match="falloff"):
            resolve_layers(body_tube(), noisy_sleeves(), falloff=falloff)


def test_an_inside_out_body_gives_the_result_of_the_body_it_is():
    """A body with flipped winding (or mirrored by a negative scale) is taken the right way out:
    the same result to the bit, and the stats say so. (It used to move cloth 22.7 mm off.)"""
    body, garments = body_tube(), noisy_sleeves()
    right = resolve_layers(body, garments)
    flipped = resolve_layers(mesh(body.vertices, body.faces[:, ::-1]), garments)
    assert flipped.stats["body_inside_out"] and not right.stats["body_inside_out"]
    for a, b in zip(right.garments, flipped.garments, strict=True):
        np.testing.assert_array_equal(a.vertices, b.vertices)
        np.testing.assert_array_equal(a.faces, b.faces)
    # a mirrored body (x -> -x) winds inward too: taken as the mirror image of the same body
    mirror = np.array([-1.0, 1.0, 1.0])
    mirrored = resolve_layers(mesh(body.vertices * mirror, body.faces), [mesh(g.vertices * mirror, g.faces)
                                                                          for g in garments])
    assert mirrored.stats["body_inside_out"]
    for a, b in zip(right.garments, mirrored.garments, strict=True):
        np.testing.assert_allclose(a.vertices * mirror, b.vertices, atol=1e-9)


def test_turning_the_scene_changes_no_default_and_moves_the_result_with_it():
    """The defaults taken from the body's size (offset, the part-border margin) are the same however
    the scene is turned (an axis-aligned box's diagonal is not), and the result turns with it,
    the inner sleeve to 0.1 mm, the outer one, only lifted, to a micrometre."""
    from scipy.spatial.transform import Rotation

    body, garments = body_tube(), noisy_sleeves(n=40)
    right = resolve_layers(body, garments)
    turn, shift = Rotation.from_euler("xyz", [35, -50, 20], degrees=True).as_matrix(), np.array([0.3, -1.2, 2.0])
    moved = resolve_layers(mesh(body.vertices @ turn.T + shift, body.faces),
                           [mesh(g.vertices @ turn.T + shift, g.faces) for g in garments])
    # (a round tube's principal axes across it are any two, picked by the LAPACK build: the body's
    # 64-gon is 2R cos(pi/64) to 2R wide, which moves the diagonal by up to 2e-4 of itself)
    assert moved.stats["offset"] == pytest.approx(right.stats["offset"], rel=3e-4)
    assert moved.stats["gap"] == pytest.approx(right.stats["gap"], rel=3e-4)
    back = [(g.vertices - shift) @ turn for g in moved.garments]
    np.testing.assert_allclose(back[1], right.garments[1].vertices, rtol=0, atol=1e-6)
    np.testing.assert_allclose(back[0], right.garments[0].vertices, rtol=0, atol=1e-4)


def _bound_tube(rings, radius, n=64, dz=0.6 / 32):
    """A tube on the body tube's own vertex lines (its angles, its rings ``rings``), as
    garments bound vertex by vertex to the body are: ``radius(theta, z)``."""
    theta = np.linspace(0, 2 * np.pi, n, endpoint=False)
    tt, zz = np.meshgrid(theta, dz * np.arange(rings[0], rings[1] + 1))
    r = radius(tt, zz)
    v = np.column_stack([(r * np.cos(tt)).ravel(), (r * np.sin(tt)).ravel(), zz.ravel()])
    i, j = np.meshgrid(np.arange(len(zz) - 1), np.arange(n), indexing="ij")
    a, b = i * n + j, i * n + (j + 1) % n
    f = np.concatenate([np.stack([a, b, b + n], -1).reshape(-1, 3), np.stack([a, b + n, a + n], -1).reshape(-1, 3)])
    return mesh(v, f)


def test_garments_bound_to_the_same_body_points_resolve_alike_however_the_scene_is_turned():
    """MakeHuman binds garments vertex by vertex to the body, so a lower garment's vertex can lie
    exactly on the normal line through a higher garment's hem vertex: a probe along it met the
    hem's corner or just missed it by float32 round-off, and which changed with the scene's
    orientation (2.4 mm on MakeHuman's casual suit over its sports suit; here 0.5 mm). Within
    0.1 mm now."""
    from scipy.spatial.transform import Rotation

    body = mesh(*tube(0.15, 0.0, 0.6, grid=(64, 33), capped=True))
    lower = _bound_tube((10, 26), lambda t, z: 0.1585 + 0.004 * np.cos(3 * t) * np.cos(9 * z))
    upper = _bound_tube((16, 30), lambda t, z: 0.162 + 0.002 * np.sin(2 * t + 7 * z))
    right = resolve_layers(body, [lower, upper])
    assert brute_crossings(*(lambda g: (g[0].vertices, g[0].faces, g[1].vertices, g[1].faces))(right.garments)) == 0
    for angles in ([35, -50, 20], [10, 0, 0], [0, 80, 0]):
        turn, shift = Rotation.from_euler("xyz", angles, degrees=True).as_matrix(), np.array([0.3, -1.2, 2.0])
        moved = resolve_layers(mesh(body.vertices @ turn.T + shift, body.faces),
                               [mesh(g.vertices @ turn.T + shift, g.faces) for g in (lower, upper)])
        for a, b in zip(right.garments, moved.garments, strict=True):
            np.testing.assert_allclose((b.vertices - shift) @ turn, a.vertices, rtol=0, atol=1e-4, err_msg=str(angles))


def test_a_part_id_far_beyond_the_parts_is_refused_before_anything_is_allocated():
    """An id of 1e7 asked for a 1e7 x 1e7 table of part links (90 TiB): a message instead."""
    body = body_tube()
    ids = np.zeros(len(body.vertices), np.int64)
    ids[0] = 10_000_000
    with pytest.raises(ValueError, match=r"number the body's parts 0..k-1"):
        resolve_layers(body, noisy_sleeves(), body_segments=ids)
    ids[0] = 7  # sparse ids within the bound are fine
    s, j = resolve_layers(body, noisy_sleeves(), body_segments=ids).garments
    assert brute_crossings(s.vertices, s.faces, j.vertices, j.faces) == 0


def test_a_large_offset_never_pushes_garments_into_the_body():
    """Four noisy layers a few mm apart and d = 5 mm: not enough room, so gaps compress."""
    body = body_tube(n=40)
    garments = noisy_sleeves(radii=(0.163, 0.166, 0.169, 0.172), noise=0.01, n=40, z0_step=0.04)
    res = resolve_layers(body, garments, offset=0.005)
    for g in res.garments:
        assert brute_crossings(body.vertices, body.faces, g.vertices, g.faces) == 0
        assert radial(g.vertices).min() > 0.15
    assert res.stats["vertices_held_by_body"] > 0


def test_culled_hem_scenes_give_the_same_hits_as_the_whole_layer():
    from core.geometry.topology import boundary_vertices
    from core.layering.tracer import HitRules, LayerLayout, Probes, SegmentScenes, trace_layers

    lower, upper = noisy_sleeves(n=48)
    f = np.asarray(lower.faces)
    layout = LayerLayout(f, np.zeros(len(f), int), np.eye(1, dtype=bool))
    scenes = [SegmentScenes(np.asarray(lower.vertices), layout)]
    hem = np.flatnonzero(boundary_vertices(upper.faces, len(upper.vertices)))
    o = np.asarray(upper.vertices)[hem]
    n = np.column_stack([o[:, :2], np.zeros(len(o))])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    for sign in (1, -1):
        reach = np.full(len(o), 0.03)
        culled = trace_layers(Probes(o, sign * n, reach, np.zeros(len(o), int)), scenes, [0], HitRules(cull=True))
        t_cull, f_cull = culled.t, culled.face
        full = scenes[0].full().intersect(o, sign * n, max_dist=reach)
        assert (np.isfinite(t_cull) == full.hit).all() and full.hit.any()
        np.testing.assert_allclose(t_cull[full.hit], full.t[full.hit], atol=1e-12)
        # the same triangle, or (a ray through a shared edge or corner) a neighbour of it
        a, b = f[f_cull[full.hit]], f[full.face[full.hit]]
        assert (a[:, :, None] == b[:, None, :]).any((1, 2)).all()
    # and the culled scene really is a part of the layer (the hems' bands)
    _, ids = SegmentScenes(np.asarray(lower.vertices), layout).get_near(np.arange(len(f)), o, 0.03)
    assert len(ids) < 0.5 * len(f)


def test_one_scene_per_layer_gives_each_ray_only_its_own_segments_hits():
    """Rays are traced against one scene of the whole layer and pass over triangles of parts
    they may not meet: the answer is brute force over just the triangles they may meet."""
    from core.layering.tracer import HitRules, LayerLayout, Probes, SegmentScenes, trace_layers
    from tests.core.brute import moller_trumbore

    lower, upper = noisy_sleeves(n=32)
    v, f = np.asarray(upper.vertices), np.asarray(upper.faces)
    angle = lambda p: np.arctan2(p[..., 1], p[..., 0])  # noqa: E731
    fseg = np.digitize(angle(v[f].mean(1)), [-1.0, 1.5])  # three wedges of the sleeve
    links = np.eye(3, dtype=bool)
    links[0, 1] = links[1, 0] = True
    o = np.asarray(lower.vertices)
    rng = np.random.default_rng(4)
    # outward, tilted at random: rays straight along the grid's columns would pass exactly
    # through edges, where the brute force (not watertight) misses both triangles
    out = np.column_stack([o[:, :2], np.zeros(len(o))]) / np.linalg.norm(o[:, :2], axis=1)[:, None]
    out += rng.normal(scale=0.05, size=out.shape)
    out /= np.linalg.norm(out, axis=1, keepdims=True)
    # wedges by the vertex's own angle, shifted so many rays start in one wedge and look into another
    segs = np.column_stack([np.digitize(angle(o) + 0.3, [-1.0, 1.5]), np.full(len(o), -1)])
    border = rng.random(len(o)) < 0.2
    segs[border, 1] = rng.integers(0, 3, border.sum())
    reach = np.full(len(o), 0.04)
    allowed = links[segs[:, 0]] | np.where(segs[:, 1:] >= 0, links[np.maximum(segs[:, 1], 0)], False)
    for farthest in (False, True):
        scenes = [SegmentScenes(v, LayerLayout(f, fseg, links))]
        traced = trace_layers(Probes(o, out, reach, segs), scenes, [0], HitRules(farthest=farthest))
        t, layer, face = traced.t, traced.layer, traced.face
        # brute force per set of parts a ray may meet; the farthest hit within reach is the
        # nearest one coming back from the far end
        start, way = (o + 0.04 * out, -out) if farthest else (o, out)
        t_ref = np.full(len(o), np.inf)
        for key in np.unique(allowed, axis=0):
            rows = np.flatnonzero((allowed == key).all(1))
            ids = np.flatnonzero(key[fseg])
            t_key, _ = moller_trumbore(start[rows], way[rows], v, f[ids], 0.0, 0.04)
            t_ref[rows] = 0.04 - t_key if farthest else t_key
        hit = np.isfinite(t_ref)
        assert hit.sum() > 100 and (~hit).sum() > 100  # both kinds, and rays whose first hit was not theirs
        assert ((layer == 0) == hit).all()
        np.testing.assert_allclose(t[hit], t_ref[hit], atol=1e-9)
        assert allowed[hit, fseg[face[hit]]].all()


def test_segment_bounds_are_the_boxes_of_the_triangles_each_segment_may_meet():
    from core.layering.tracer import LayerLayout, SegmentScenes

    lower, _ = noisy_sleeves(n=24)
    v, f = np.asarray(lower.vertices), np.asarray(lower.faces)
    seg = (v[f].mean(1)[:, 2] > np.median(v[:, 2])).astype(int)  # two segments, bottom and top
    seg[v[f].mean(1)[:, 0] > 0.5 * v[:, 0].max()] = 2  # a third on one side
    links = np.eye(3, dtype=bool)
    links[0, 2] = links[2, 0] = True
    scenes = SegmentScenes(v, LayerLayout(f, seg, links))
    for s in range(3):
        tri = v[f[links[s][seg]]].reshape(-1, 3)
        lo, hi = tri.min(0), tri.max(0)
        # asked first (when the boxes are made) and asked again give the same answers
        assert not SegmentScenes(v, LayerLayout(f, seg, links)).bounds_overlap(s, hi + 1e-9, hi + 1.0)
        assert scenes.bounds_overlap(s, lo, hi)
        # boxes touching it at either corner overlap; boxes just beside it do not
        assert scenes.bounds_overlap(s, hi, hi + 1.0) and scenes.bounds_overlap(s, lo - 1.0, lo)
        assert not scenes.bounds_overlap(s, hi + 1e-9, hi + 1.0)
        assert not scenes.bounds_overlap(s, lo - 1.0, lo - 1e-9)
        for axis in range(3):  # and on each axis: the box is exact on every side
            step = np.eye(3)[axis] * 1e-9
            assert not scenes.bounds_overlap(s, lo - 1.0, lo + (hi - lo) * (1 - np.eye(3)[axis]) - step)


def test_a_joint_bulging_beside_the_probe_ray_still_holds_the_lower_layer_out():
    """A ball joint sits on the limb; a sleeve squeezed over it is pushed along the limb's
    normals, which pass beside the ball. The body floor must see the ball anyway."""
    from sample_scenes.shapes import tube

    arm = capped_cylinder(0.04, 0.6, n=48)
    ball = trimesh.creation.icosphere(subdivisions=4, radius=0.05)
    ball.apply_translation([0.0, 0.0, 0.0])
    body = trimesh.util.concatenate([arm, ball])
    # the sleeve hugs the ball (6 mm out); the outer sleeve sits inside it, 2 mm off the arm
    sv, sf = tube(0.056, -0.1, 0.1, grid=(48, 24))
    ov, of = tube(0.042, -0.2, 0.2, grid=(48, 40))
    sleeve, outer = mesh(sv, sf), mesh(ov, of)
    res = resolve_layers(body, [sleeve, outer], offset=0.001)
    s = res.garments[0]
    assert brute_crossings(s.vertices, s.faces, body.vertices, body.faces) == 0
    assert res.stats["vertices_held_by_body"] > 0


def _fold_scene(lower_z=0.029):
    """A lower sheet 1 mm under a higher layer folded back on itself: its outer sheet at 3 cm
    and, under the middle, the fold's inner sheet at 1.2 cm."""
    body = slab_body()
    low_v, low_f = sheet(n=31, z=lower_z)
    out_v, out_f = sheet(size=1.1, n=34, z=0.03)
    in_v, in_f = sheet(size=0.5, n=16, z=0.012)
    fold = mesh(np.vstack([out_v, in_v]), np.vstack([out_f, in_f + len(out_v)]))
    return body, mesh(low_v, low_f), fold


def test_a_lower_layer_inside_a_fold_goes_behind_both_sheets():
    body, low, fold = _fold_scene()
    d = 0.002
    res = resolve_layers(body, [low, fold], offset=d, probe_distance=0.05, boundary_pass=False)
    v = res.garments[0].vertices
    under = (np.abs(low.vertices[:, :2]) < 0.15).all(1)  # under the fold, away from its rim
    # behind the farthest sheet of the layer within reach, not the nearest
    np.testing.assert_allclose(v[under, 2], 0.012 - d, atol=1e-9)
    assert v[:, 2].max() <= 0.03 - d + 1e-9  # everywhere behind the outer sheet
    # resolving the result again finds nothing left to do
    again = resolve_layers(body, res.garments, offset=d, probe_distance=0.05, boundary_pass=False)
    assert max(float(np.abs(m).max()) for m in again.moved) < 1e-9
    assert again.stats["faces_removed"] == 0


def test_vertices_of_no_triangle_are_left_where_they_are():
    body, low, fold = _fold_scene()
    loose = np.array([[0.0, 0.0, 0.05], [0.3, 0.1, 0.02]])  # in front of the higher layer
    with_loose = mesh(np.vstack([low.vertices, loose]), low.faces)
    res = resolve_layers(body, [with_loose, fold], offset=0.002, probe_distance=0.05)
    ref = resolve_layers(body, [low, fold], offset=0.002, probe_distance=0.05)
    assert not res.moved[0][len(low.vertices):].any()
    np.testing.assert_array_equal(res.moved[0][:len(low.vertices)], ref.moved[0])
    assert res.stats["rays_push"] == ref.stats["rays_push"]


def test_a_sheet_facing_the_other_way_does_not_stop_the_probe():
    """Probe rays pass a higher layer's sheet whose global normal faces away (the far side of a
    skirt seen through the legs) and still find the facing sheets beyond it."""
    body = slab_body()
    low_v, low_f = sheet(n=21, z=0.029)
    parts = [sheet(size=1.1, n=23, z=z) for z in (0.03, 0.015, 0.005)]
    high = mesh(np.vstack([p[0] for p in parts]),
                np.vstack([p[1] + i * len(parts[0][0]) for i, p in enumerate(parts)]))
    up = np.tile([0.0, 0.0, 1.0], (len(high.vertices), 1))
    up[2 * len(parts[0][0]):] *= -1  # the bottom sheet faces down
    d = 0.002
    res = resolve_layers(body, [mesh(low_v, low_f), high], offset=d, probe_distance=0.05, boundary_pass=False,
                         global_normals=[np.tile([0.0, 0.0, 1.0], (len(low_v), 1)), up])
    np.testing.assert_allclose(res.garments[0].vertices[:, 2], 0.015 - d, atol=1e-9)


def test_the_inner_shell_of_a_garment_with_thickness_is_not_lifted():
    """A garment with two shells, as Solidify makes it (the inner one facing the body), sunk 1 mm into
    a tube body: its outer shell is lifted to the floor, its inner shell, behind the outer, is not."""
    body = body_tube(n=48)
    outer_v, faces = tube(0.149, 0.12, 0.48, grid=(48, 24))
    inner_v, _ = tube(0.147, 0.12, 0.48, grid=(48, 24))
    shell = mesh(np.vstack([outer_v, inner_v]), np.vstack([faces, faces[:, ::-1] + len(outer_v)]))
    over = mesh(*tube(0.17, 0.1, 0.5, grid=(48, 24)))
    res = resolve_layers(body, [shell, over], boundary_pass=False, push_behind=False, body_guard=False,
                         remove_hidden=False)
    moved = np.linalg.norm(res.moved[0], axis=1)
    assert (moved[:len(outer_v)] > 0.001).all()  # out of the body, to the floor
    assert not moved[len(outer_v):].any()


def test_a_higher_layer_near_the_end_of_the_probe_is_still_found():
    """The push probe starts a gap out and reaches l_s past its vertex: a higher sheet lying
    l_s - gap/2 beneath a lower one is within reach, and the lower sheet goes a gap behind it."""
    body = slab_body(size=1.0, thickness=0.2, subdivisions=4)
    reach, offset = 0.03, 0.004
    low = mesh(*sheet(size=0.4, n=21, z=0.05))
    high = mesh(*sheet(size=0.2, n=11, z=0.05 - (reach - offset / 2)))
    res = resolve_layers(body, [low, high], probe_distance=reach, offset=offset, boundary_pass=False,
                         body_guard=False, remove_hidden=False)
    over = (np.abs(low.vertices[:, :2]) < 0.09).all(1)  # under the patch, away from its edge
    np.testing.assert_allclose(res.garments[0].vertices[over, 2], high.vertices[0, 2] - res.stats["gap"], atol=1e-6)
    assert np.allclose(res.moved[0][~(np.abs(low.vertices[:, :2]) < 0.11).all(1)], 0.0)


def test_the_body_guard_takes_back_a_move_into_the_body_and_keeps_one_that_only_fails_to_take_cloth_out():
    """A coarse sheet over a box: its middle vertex moved 30 cm down goes into the box, and the
    move is halved until no edge or triangle passes through it (brute force: none does); with the
    vertex inside the box already, a move that leaves it inside is kept when ``through_before`` says
    that cloth through the body before may stay so (the lift's and easing's guard on simulated
    cloth), and taken back otherwise (the guard on the stages' moves)."""
    from core.layering.body_facts import body_facts
    from core.layering.body_guard import Cloth, back_off

    box = trimesh.creation.box(extents=(0.4, 0.4, 0.4))
    body = body_facts(np.asarray(box.vertices, float), np.asarray(box.faces))
    v, f = sheet(size=1.0, n=5, z=0.3)
    edges = unique_edges(f)
    middle = int(np.argmin(np.linalg.norm(v[:, :2], axis=1)))
    cloth = Cloth(f, edges)
    down = v.copy()
    down[middle, 2] = 0.0
    assert brute_crossings(down, f, box.vertices, box.faces) > 0
    out, n = back_off(body, cloth, v, down, np.zeros(len(v)), through_before=True)
    assert n == 1 and brute_crossings(out, f, box.vertices, box.faces) == 0
    assert v[middle, 2] > out[middle, 2] > 0.2  # part of the move kept: above the box's top
    up = down.copy()
    up[middle, 2] = 0.05  # still inside the box
    kept, n_kept = back_off(body, cloth, down, up, np.zeros(len(v)), through_before=True)
    assert n_kept == 0 and np.array_equal(kept, up)
    taken, n_taken = back_off(body, cloth, down, up, np.zeros(len(v)))
    assert n_taken == 1 and taken[middle, 2] < up[middle, 2]
