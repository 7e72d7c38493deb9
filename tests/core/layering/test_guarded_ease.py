"""Playback's easing on simulated cloth kept out of the body (resolve._guard_ease) where the body
points came from the last frame: their distance bounds the body's from above only, so it must not
spare an edge from the guard. Measured against the floor's own plane: z < 0 is through it."""

from types import SimpleNamespace

import numpy as np
import pytest

from core.geometry.topology import edges_with_counts
from core.layering import resolve
from core.layering.body_facts import body_facts
from core.layering.layer_stack import LayerStack


def _grid(n, size):
    """An n x n square of vertices, ``size`` wide, two triangles a cell, in the plane z = 0."""
    x, y = np.meshgrid(np.linspace(-size / 2, size / 2, n), np.linspace(-size / 2, size / 2, n))
    v = np.column_stack([x.ravel(), y.ravel(), np.zeros(n * n)])
    i = np.arange(n * n).reshape(n, n)[:-1, :-1].ravel()
    f = np.concatenate([np.column_stack([i, i + 1, i + n + 1]), np.column_stack([i, i + n + 1, i + n])])
    return v, f


def _stack(carried, clearance):
    """One sheet 5 mm over a 4 m floor (the body), as a LayerStack holds it. ``carried``: its body
    points were passed in from the last frame (a correspondence given); ``clearance``: what the
    stack holds for each vertex's distance from the body."""
    floor = body_facts(np.array([[-2.0, -2.0, 0.0], [2.0, -2.0, 0.0], [2.0, 2.0, 0.0], [-2.0, 2.0, 0.0]]),
                       np.array([[0, 1, 2], [0, 2, 3]]))
    v, f = _grid(8, 0.4)
    v = v + [0.0, 0.0, 0.005]
    stack = SimpleNamespace(body=floor, faces=[f], edges=[edges_with_counts(f)[0]], verts=[v],
                            clearance=[np.full(len(v), clearance)], backed_off=0,
                            params=SimpleNamespace(correspondence=[object() if carried else None]))
    stack.guard_clearance = lambda k: LayerStack.guard_clearance(stack, k)
    return stack, v


@pytest.mark.parametrize("carried, clearance", [(True, 1.0), (False, 0.005)])
def test_easing_that_would_dip_the_cloth_through_the_floor_is_taken_back(carried, clearance):
    """Eased 8 mm down from 5 mm over the floor, a patch in the sheet's middle would dip 3 mm under
    it, its edges through the floor. Taken back (halved, down to 1 mm over it): every vertex stays
    over the floor and only the patch's moves change. With body points carried from the last frame
    the stack's clearance (here the 1 m to a body point the sheet has slid away from) is no lower
    bound on the distance from the floor, and is not taken for one."""
    stack, own = _stack(carried, clearance)
    patch = np.flatnonzero(np.hypot(own[:, 0], own[:, 1]) < 0.06)
    assert 0 < len(patch) < len(own) // 4
    eased = own.copy()
    eased[patch, 2] -= 0.008
    out = resolve._guard_ease(stack, 0, own, eased)
    assert out[:, 2].min() >= 0.0
    np.testing.assert_array_equal(np.delete(out, patch, axis=0), np.delete(eased, patch, axis=0))
    np.testing.assert_allclose(out[patch, 2], 0.001, atol=1e-12)
    assert stack.backed_off == len(patch)


def test_easing_clear_of_the_floor_is_kept_whole():
    """Eased 3 mm down from 5 mm, the patch stays 2 mm over the floor: nothing is taken back."""
    stack, own = _stack(True, 1.0)
    eased = own.copy()
    eased[np.hypot(own[:, 0], own[:, 1]) < 0.06, 2] -= 0.003
    np.testing.assert_array_equal(resolve._guard_ease(stack, 0, own, eased), eased)
    assert stack.backed_off == 0


def test_the_guard_takes_a_searched_clearance_and_none_carried():
    """guard_clearance: the stack's clearance where the body points were searched this frame; zero
    where they were passed in."""
    stack, own = _stack(False, 0.005)
    np.testing.assert_array_equal(stack.guard_clearance(0), np.full(len(own), 0.005))
    stack, own = _stack(True, 0.005)
    np.testing.assert_array_equal(stack.guard_clearance(0), np.zeros(len(own)))
