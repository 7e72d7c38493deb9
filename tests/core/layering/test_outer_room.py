"""The outer room stage: a higher layer's edges that still pass through a lower layer the body holds go
out, by at most MOST gaps, and nothing else of it moves."""

import numpy as np

from core.layering import resolve_layers
from core.layering.outer_room import MOST
from tests.core.brute import brute_crossings
from tests.core.layered_cases import body_tube
from tests.core.layering.test_frames import _dented


def test_a_higher_layer_dipping_onto_a_held_lower_layer_goes_out_over_it_and_nowhere_else():
    body = body_tube()
    low, high = _dented(True)  # the higher sleeve dips to 1.5 mm off the body: the lower one has no room
    without = resolve_layers(body, [low, high], outer_room=False)
    res = resolve_layers(body, [low, high])
    assert without.stats["vertices_moved_room"] == 0 < res.stats["vertices_moved_room"]

    def crossing(r):  # every edge against every triangle, nothing hidden
        return brute_crossings(low.vertices + r.moved[0], low.faces, high.vertices + r.moved[1], high.faces)

    before, after = crossing(without), crossing(res)
    assert before > 0 and after <= 0.5 * before
    assert res.removed_faces[0].sum() < without.removed_faces[0].sum()
    np.testing.assert_array_equal(res.moved[0], without.moved[0])  # the lower layer is where it was
    went = res.moved[1] - without.moved[1]
    out = np.linalg.norm(went, axis=1)
    radial = high.vertices[:, :2] / np.linalg.norm(high.vertices[:, :2], axis=1, keepdims=True)
    moved = out > 0
    # out along the sleeve's normals (the tube's radial direction), by at most MOST gaps
    assert (np.einsum("ij,ij->i", went[moved, :2], radial[moved]) > 0.99 * out[moved]).all()
    assert out.max() <= MOST * res.stats["gap"] * (1 + 1e-9)
    # only over the dent: the patch 0.35 rad either side of +x, 6 cm either side of z = 0.3, and an edge round it
    ang = np.arctan2(high.vertices[:, 1], high.vertices[:, 0])
    near = (np.abs(ang) < 0.35 + 0.2) & (np.abs(high.vertices[:, 2] - 0.3) < 0.06 + 0.02)
    assert moved.any() and not (moved & ~near).any()


def test_with_room_behind_the_lower_layer_the_higher_one_stays():
    """Without the dent the lower sleeve has room, nothing crosses, and the stage moves nothing."""
    body = body_tube()
    res = resolve_layers(body, _dented(False))
    assert res.stats["vertices_moved_room"] == 0
    np.testing.assert_array_equal(res.moved[1], resolve_layers(body, _dented(False), outer_room=False).moved[1])


def test_before_a_subdivision_the_lift_is_one_ring_wider_and_as_high():
    """With a Subdivision Surface after the correction, each lifted vertex's neighbours go out as far
    (a bump one edge wide would be smoothed back through the lower layer): the vertices moved are
    the ones moved without it and every neighbour of one, each by the most of its own and theirs."""
    body = body_tube()
    low, high = _dented(True)
    plain = resolve_layers(body, [low, high], outer_room=False)
    base = np.linalg.norm(resolve_layers(body, [low, high]).moved[1] - plain.moved[1], axis=1)
    wide = np.linalg.norm(resolve_layers(body, [low, high], subdivided=[False, True]).moved[1] - plain.moved[1], axis=1)
    neighbours = [set() for _ in range(len(high.vertices))]
    for f in high.faces:
        for a in f:
            neighbours[a].update(int(b) for b in f if b != a)
    expected = np.array([max([base[v]] + [base[u] for u in neighbours[v]]) for v in range(len(base))])
    assert (wide > 0).sum() > (base > 0).sum()
    np.testing.assert_allclose(wide, expected, atol=1e-12)


def test_a_middle_layers_lift_stops_an_offset_short_of_every_layer_over_it():
    """The cap of a middle layer, against the analytic room: layer 0 a flat sheet asked to go up 20 mm
    at every vertex, layer 1 a smaller sheet 10 mm over its middle and layer 2 one 15 mm over a
    corner. Under layer 1 the lift is 10 mm less the offset; under layer 2 alone 15 mm less it; under
    neither the full 20 mm; and the top layer, with nothing over it, keeps its whole lift."""
    from types import SimpleNamespace

    from core.layering.outer_room import _below_the_next
    from core.rays.scene import RayScene
    from tests.core.layered_cases import sheet

    offset = 0.002
    v0, f0 = sheet(1.0, 21)
    v1, f1 = sheet(0.4, 9, z=0.010)
    v2, f2 = sheet(0.3, 7, z=0.015)
    v2[:, :2] += 0.28  # over the corner x, y > 0.13 only: it overlaps layer 1 there
    layers = [(v0, f0), (v1, f1), (v2, f2)]
    traced = [RayScene(v, f) for v, f in layers]
    scenes = [SimpleNamespace(full=lambda s=s: s) for s in traced]
    stack = SimpleNamespace(above=lambda k: [j for j in range(3) if j > k], verts=[v for v, _ in layers],
                            normals=[np.tile([0.0, 0.0, 1.0], (len(v), 1)) for v, _ in layers],
                            scenes=scenes, params=SimpleNamespace(offset=offset))
    lift = np.full(len(v0), 0.020)
    lift[::7] = 0.0  # not asked: stays
    got = _below_the_next(stack, 0, lift)
    x, y = v0[:, 0], v0[:, 1]
    inside = 1e-9
    under1 = (np.abs(x) <= 0.2 + inside) & (np.abs(y) <= 0.2 + inside)
    under2 = (x >= 0.13 - inside) & (x <= 0.43 + inside) & (y >= 0.13 - inside) & (y <= 0.43 + inside)
    edge = ((np.abs(np.abs(x) - 0.2) < 1e-6) | (np.abs(np.abs(y) - 0.2) < 1e-6) | (np.abs(x - 0.13) < 1e-6)
            | (np.abs(y - 0.13) < 1e-6) | (np.abs(x - 0.43) < 1e-6) | (np.abs(y - 0.43) < 1e-6))
    want = np.where(under1, 0.010 - offset, np.where(under2, 0.015 - offset, 0.020))
    want[::7] = 0.0
    assert (under1 & under2 & ~edge).any()  # where both lie over it, the nearer one caps
    clear = ~edge  # on a sheet's rim a ray may graze past it: either answer is right there
    np.testing.assert_allclose(got[clear], want[clear], atol=1e-9)
    assert (got[under1 & clear & (lift > 0)] > 0).all() and (got <= lift).all()
    np.testing.assert_array_equal(_below_the_next(stack, 2, lift[:len(v2)]), lift[:len(v2)])
