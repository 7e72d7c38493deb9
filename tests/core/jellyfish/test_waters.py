"""The registry of waters: every config, menu and stored stroke names a water from it."""

import numpy as np
import pytest

from core.jellyfish import WATERS, default_config
from core.jellyfish.bell import BellShape, contour, polygon_area
from core.jellyfish.waters import lattice_for


def test_an_unknown_water_is_refused_naming_the_known_ones():
    with pytest.raises(ValueError, match="'axisymmetric', 'planar'.*'ocean'"):
        default_config(fluid="ocean")


def test_round_the_axis_needs_an_even_lattice_the_planar_water_does_not():
    with pytest.raises(ValueError, match="even round the axis"):
        default_config(particles=61)
    assert default_config(particles=61, fluid="planar").particles == 61


@pytest.mark.parametrize("key", sorted(WATERS))
def test_each_water_puts_the_axis_where_its_lattice_is_symmetric(key):
    """The bell's axis sits on the lattice's mirror (round the axis: x = 0) or in the middle of
    the periodic box (planar): the particles lie symmetrically about it."""
    cfg = default_config(particles=20, fluid=key)
    water = WATERS[key]
    x = lattice_for(cfg).points[:, 0] - water.axis_x(cfg)
    if key == "axisymmetric":
        assert (x > 0).all() and x.max() < 0.5 * cfg.box
    else:
        np.testing.assert_allclose(np.sort(x), np.sort(-x), atol=1e-12)


def test_the_planar_section_is_its_area_and_the_turned_one_pappus():
    """Planar: the polygon's area (bell.polygon_area, written apart). Round the axis: the right
    half's area times the path of its centroid, 2 pi x_c, against a fine numerical quadrature."""
    shape = BellShape()
    rest, left = contour(shape)
    area, _ = WATERS["planar"].section_volume(rest, left)
    assert area == pytest.approx(polygon_area(rest), rel=1e-12)
    volume, _ = WATERS["axisymmetric"].section_volume(rest, left)
    # the volume of revolution by shells: the section's right half, 2 pi r times its height at r
    half = np.vstack([rest[:left // 2 + 1], rest[left + left // 2:]])
    r = np.linspace(0, half[:, 0].max(), 20001)[1:-1]
    heights = []
    edges = np.stack([half, np.roll(half, -1, axis=0)], 1)
    for x in r:
        a, b = edges[(edges[:, 0, 0] - x) * (edges[:, 1, 0] - x) < 0].transpose(1, 0, 2)
        y = np.sort(a[:, 1] + (x - a[:, 0]) * (b[:, 1] - a[:, 1]) / (b[:, 0] - a[:, 0]))
        heights.append(float((y[1::2] - y[0::2]).sum()))
    f = 2 * np.pi * r * np.array(heights)
    shells = float(((f[1:] + f[:-1]) * np.diff(r)).sum() / 2)  # the trapezoid rule
    assert volume == pytest.approx(shells, rel=1e-3)
