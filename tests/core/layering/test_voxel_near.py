"""The voxel test that picks the triangles near hem points, against brute-force distances."""

import tracemalloc

import numpy as np
import pytest
from scipy.spatial import cKDTree

from core.layering.tracer import voxel_near


def _nearest(centres, points, p):
    return cKDTree(points).query(centres, p=p)[0]


@pytest.mark.parametrize("scale", [1e-3, 1.0, 1e3])
def test_every_centre_within_a_cell_is_kept_and_none_beyond_the_next_voxel(scale):
    rng = np.random.default_rng(3)
    points = rng.normal(size=(400, 3)) * scale
    centres = rng.uniform(-4, 4, size=(20000, 3)) * scale
    cell = 0.3 * scale
    near = voxel_near(centres, cell, points)
    assert near[_nearest(centres, points, 2) <= cell].all()
    # a kept centre is in a point's voxel or one next to it: under two cells away on every axis
    assert (_nearest(centres[near], points, np.inf) < 2 * cell * (1 + 1e-9)).all()
    assert 0 < near.sum() < len(centres)


def test_a_cell_too_small_for_the_grid_keeps_everything_within_it():
    # a kilometre of points and a millimetre cell: a grid of 10^18 voxels; a coarser one is used
    rng = np.random.default_rng(4)
    points = rng.uniform(0, 1000.0, size=(300, 3))
    centres = np.concatenate([points + rng.uniform(-1e-3, 1e-3, size=points.shape) * 0.5,
                              rng.uniform(-500, 1500, size=(5000, 3))])
    tracemalloc.start()
    near = voxel_near(centres, 1e-3, points)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 64e6
    assert near[_nearest(centres, points, 2) <= 1e-3].all()
    assert near[:len(points)].all()


def test_flat_and_single_point_sets_and_far_centres():
    flat = np.column_stack([np.linspace(0, 1, 50), np.zeros(50), np.zeros(50)])  # no spread in y, z
    centres = np.array([[0.5, 0.05, 0.0], [0.5, 0.0, -0.05], [0.5, 5.0, 0.0], [-3.0, 0.0, 0.0], [2.0, 0, 0]])
    assert voxel_near(centres, 0.1, flat).tolist() == [True, True, False, False, False]
    one = np.array([[1.0, 2.0, 3.0]])
    assert voxel_near(np.array([[1.0, 2.0, 3.0], [1.05, 2.0, 3.0], [9.0, 9.0, 9.0]]), 0.1, one).tolist() == \
        [True, True, False]
    assert not voxel_near(centres, 0.0, flat).any()
    assert voxel_near(np.zeros((0, 3)), 0.1, flat).shape == (0,)
