"""Ray scenes kept between resolves: the same answers as scenes made afresh, never stale, within
their memory budget."""

import numpy as np
import trimesh

from core.geometry.keys import digest
from core.layering import resolve_layers
from core.layering.body_facts import forget_garments
from core.rays import scene_cache
from tests.core.brute import moller_trumbore
from tests.core.layered_cases import body_tube, noisy_sleeves


def _rays(n, seed=0):
    rng = np.random.default_rng(seed)
    o = rng.normal(size=(n, 3)) * 0.3
    d = rng.normal(size=(n, 3))
    return o, d / np.linalg.norm(d, axis=1, keepdims=True)


def test_a_kept_scene_is_built_over_its_own_copy_and_hits_what_brute_force_hits():
    scene_cache.forget_scenes()
    m = trimesh.creation.icosphere(subdivisions=2)
    v, f = np.array(m.vertices), np.array(m.faces)
    key = digest(v, f)
    first, kept = scene_cache.kept_scene(key, v, f)
    assert not kept
    v *= 3.0  # the caller writes into its array after: the kept scene must not follow
    again, kept = scene_cache.kept_scene(key, v, f)
    assert kept and again is first
    o, d = _rays(500)
    t_ref, face_ref = moller_trumbore(o, d, m.vertices, m.faces)
    hits = again.intersect(o, d)
    np.testing.assert_array_equal(hits.face, face_ref)
    np.testing.assert_allclose(hits.t[face_ref >= 0], t_ref[face_ref >= 0], atol=1e-9)


def test_the_kept_scenes_stay_within_their_budget_dropping_the_least_recently_asked(monkeypatch):
    scene_cache.forget_scenes()
    m = trimesh.creation.icosphere(subdivisions=3)  # 1,280 triangles, 642 vertices
    size = scene_cache.scene_bytes(len(m.faces), len(m.vertices))
    monkeypatch.setattr(scene_cache.KEPT, "max_bytes", int(2.5 * size))  # room for two
    meshes = [(np.array(m.vertices) + k, np.array(m.faces)) for k in range(4)]
    keys = [digest(*x) for x in meshes]
    for key, (v, f) in zip(keys[:2], meshes[:2], strict=True):
        scene_cache.kept_scene(key, v, f)
    scene_cache.kept_scene(keys[0], *meshes[0])  # asked again: now the most recent
    scene_cache.kept_scene(keys[2], *meshes[2])  # drops keys[1], the least recently asked
    assert scene_cache.kept_bytes() <= scene_cache.KEPT.max_bytes
    assert scene_cache.kept_scene(keys[0], *meshes[0])[1]
    assert scene_cache.kept_scene(keys[2], *meshes[2])[1]
    assert not scene_cache.kept_scene(keys[1], *meshes[1])[1]
    big = trimesh.creation.icosphere(subdivisions=5)  # over the whole budget: made, never kept
    scene, kept = scene_cache.kept_scene(digest(big.vertices, big.faces), big.vertices, big.faces)
    assert not kept and len(scene.faces) == len(big.faces) and scene_cache.kept_bytes() <= scene_cache.KEPT.max_bytes
    scene_cache.forget_scenes()


def _same(a, b):
    return (all(np.array_equal(x, y) for x, y in zip(a.moved, b.moved, strict=True))
            and all(np.array_equal(x.faces, y.faces) for x, y in zip(a.garments, b.garments, strict=True)))


def test_resolving_again_with_kept_scenes_equals_a_resolve_from_scratch():
    """Again with the same settings and with another offset (the scenes of the garments as they
    came are kept, those of moved layers are not), against resolves with nothing kept."""
    body = body_tube()
    garments = list(noisy_sleeves(radii=(0.165, 0.168, 0.171), n=48))
    forget_garments()
    first = resolve_layers(body, garments)
    assert first.stats["scenes_kept"] == 0 and first.stats["vertices_moved_push"] > 0
    again = resolve_layers(body, garments)
    assert again.stats["scenes_kept"] >= len(garments) - 1  # at least each layer's first scene
    assert _same(first, again)
    other = resolve_layers(body, garments, offset=0.004)
    forget_garments()
    assert _same(other, resolve_layers(body, garments, offset=0.004))


def test_a_garment_changed_in_place_after_a_resolve_gets_no_stale_scene():
    """The caller writes into the garment's own vertex array, and into the result's, between
    resolves: the next resolve must see the new positions."""
    body = body_tube()
    garments = list(noisy_sleeves(radii=(0.165, 0.17), n=48))
    forget_garments()
    first = resolve_layers(body, garments)
    first.garments[1].vertices[:] += 0.01  # a result the caller edits (the same arrays as kept?)
    outer = garments[1].vertices.view(np.ndarray)
    outer[:, :2] *= 0.97  # the outer sleeve pulled in, in place: it now crosses the inner one more
    changed = resolve_layers(body, garments)
    forget_garments()
    fresh = resolve_layers(body, [trimesh.Trimesh(g.vertices.copy(), g.faces, process=False) for g in garments])
    assert _same(changed, fresh)
    assert not _same(first, fresh)
