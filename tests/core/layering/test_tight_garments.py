"""Garments as artists make them: fitted one at a time, skin-tight (on the body or a little inside it),
with triangles several centimetres across. Checked against brute-force crossings and distances."""

import numpy as np
import trimesh

from core.layering import resolve_layers
from sample_scenes.shapes import Folds, tube
from tests.core.brute import brute_crossings
from tests.core.layered_cases import body_tube, mesh


def radial(v):
    return np.hypot(v[:, 0], v[:, 1])


def _tight(radius, z0, z1, seed, grid=(20, 12), noise=0.003):
    """A coarse sleeve whose radius wanders a few millimetres about ``radius`` (edges about 5 cm)."""
    return mesh(*tube(radius, z0, z1, grid=grid, folds=Folds(noise, np.random.default_rng(seed))))


def _inside_body(body, v):
    return trimesh.Trimesh(body.vertices, body.faces, process=False).contains(v)


def test_tight_layers_on_and_in_the_body_come_out_in_order_without_crossing():
    body = body_tube(n=96)  # radius 0.15
    top = _tight(0.1505, 0.05, 0.55, seed=1)  # on the skin, dipping into it
    leggings = _tight(0.1502, 0.1, 0.5, seed=2)  # the layer under it, as tight
    layers = [leggings, top]
    assert brute_crossings(top.vertices, top.faces, leggings.vertices, leggings.faces) > 20
    assert _inside_body(body, top.vertices).any() and _inside_body(body, leggings.vertices).any()
    res = resolve_layers(body, layers, remove_hidden=False)
    low, high = res.garments
    # no face had to be hidden for it: the layers themselves no longer cross, between their
    # vertices neither (their flat triangles bow 1-2 mm off the 15 cm tube)
    assert brute_crossings(low.vertices, low.faces, high.vertices, high.faces) == 0
    for g in (low, high):
        assert not _inside_body(body, g.vertices).any()
        assert brute_crossings(body.vertices, body.faces, g.vertices, g.faces) == 0
    assert max(np.linalg.norm(m, axis=1).max() for m in res.moved) < 0.02


def test_a_loose_layer_far_off_the_body_is_not_lifted():
    body = body_tube(n=96)
    shirt = _tight(0.165, 0.05, 0.55, seed=1)
    jacket = _tight(0.175, 0.1, 0.5, seed=2)
    res = resolve_layers(body, [shirt, jacket])
    assert res.stats["vertices_lifted_off_body"] == 0
    assert not res.moved[1].any()  # the outer layer, clear of the body and of the shirt, stays
