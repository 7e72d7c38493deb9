"""Body facts kept across calls: the same answers as computing afresh, never stale."""

import numpy as np

from core import body_facts as bf_module
from core.body_facts import body_facts, part_junctions
from core.correspondence import local_radius, vertex_normals
from core.layering import resolve_layers
from tests.core.layered_cases import body_tube, noisy_sleeves


def test_the_same_body_gives_the_same_facts_and_a_changed_one_new_facts():
    body = body_tube()
    v, f = np.asarray(body.vertices), np.asarray(body.faces)
    facts = body_facts(v, f)
    assert body_facts(v.copy(), f.copy()) is facts  # by content, not identity
    np.testing.assert_array_equal(facts.normals, vertex_normals(v, f))
    np.testing.assert_array_equal(facts.radius, local_radius(v, f))
    moved = v.copy()
    moved[0, 0] += 1e-9
    assert body_facts(moved, f) is not facts


def test_junctions_follow_the_segmentation_they_are_asked_for():
    body = body_tube()
    v, f = np.asarray(body.vertices), np.asarray(body.faces)
    facts = body_facts(v, f)
    halves = (v[:, 2] > np.median(v[:, 2])).astype(np.int64)
    thirds = np.digitize(v[:, 2], np.quantile(v[:, 2], [1 / 3, 2 / 3])).astype(np.int64)
    for seg in (halves, thirds, halves):
        got = facts.junctions(seg)
        want = part_junctions(v, f, seg)
        for a, b in zip(got, want, strict=True):
            np.testing.assert_array_equal(a, b)


def test_a_resolve_with_kept_facts_equals_one_from_scratch():
    body = body_tube()
    garments = list(noisy_sleeves(n=30))
    first = resolve_layers(body, garments)
    bf_module._kept.clear()
    again = resolve_layers(body, garments)
    for a, b in zip(first.garments, again.garments, strict=True):
        np.testing.assert_array_equal(a.vertices, b.vertices)
        np.testing.assert_array_equal(a.faces, b.faces)
