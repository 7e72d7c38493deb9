"""The body's size the defaults are taken from (parameters.body_size): its principal box's
diagonal, at most what a standing figure of its skin's area spans, against trimesh's own areas
and the box of the figure standing."""

import numpy as np
import pytest
import trimesh

from core.geometry.normals import vertex_normals, vertex_normals_and_area
from core.geometry.vectors import size_of
from core.layering import resolve_layers
from core.layering.body_facts import body_facts
from core.layering.parameters import OFFSET_SHARE, STANDING_SIZE_PER_SKIN, body_size
from sample_scenes.posed import Rig


@pytest.fixture(scope="module")
def figure():
    rig = Rig()
    return rig, {pose: rig.frame(rig.poses[pose]) for pose in ("rest", "tpose", "run01", "gym01")}


def _size(vertices, faces):
    return body_size(body_facts(np.asarray(vertices, dtype=np.float64), np.asarray(faces, dtype=np.int64)))


def test_a_figure_has_the_same_size_standing_and_with_its_arms_spread(figure):
    """MakeHuman's figure standing keeps its box's size; in a T-pose its box grows by more than a
    tenth, but its size stays within 3% of the standing one (its skin stretches that little). No
    pose makes it 5% larger; a gathered one (running) takes its smaller box."""
    rig, posed = figure
    faces = rig.body.faces
    standing = posed["rest"][0]
    assert _size(standing, faces) == pytest.approx(size_of(standing), rel=1e-12)
    spread = posed["tpose"][0]
    assert size_of(spread) > 1.1 * size_of(standing)
    skin = trimesh.Trimesh(spread, faces, process=False).area
    assert _size(spread, faces) == pytest.approx(STANDING_SIZE_PER_SKIN * np.sqrt(skin), rel=1e-9)
    assert _size(spread, faces) == pytest.approx(size_of(standing), rel=0.03)
    for pose in ("run01", "gym01"):
        v = posed[pose][0]
        assert _size(v, faces) == pytest.approx(min(size_of(v), STANDING_SIZE_PER_SKIN * np.sqrt(
            trimesh.Trimesh(v, faces, process=False).area)), rel=1e-9), pose
        assert _size(v, faces) < 1.05 * size_of(standing), pose
    assert _size(posed["run01"][0], faces) == pytest.approx(size_of(posed["run01"][0]), rel=1e-12)


def test_the_default_gap_in_a_t_pose_is_the_standing_figures(figure):
    """The resolve's default offset and the size it reports are the T-posed figure's skin's, not
    its spread box's."""
    rig, posed = figure
    body, garments = posed["tpose"]
    result = resolve_layers(trimesh.Trimesh(body, rig.body.faces, process=False),
                            [trimesh.Trimesh(v, g.faces, process=False) for v, g in zip(garments, rig.garments,
                                                                                         strict=True)])
    skin = trimesh.Trimesh(body, rig.body.faces, process=False).area
    assert result.stats["body_size"] == pytest.approx(STANDING_SIZE_PER_SKIN * np.sqrt(skin), rel=1e-9)
    assert result.stats["offset"] == pytest.approx(OFFSET_SHARE * STANDING_SIZE_PER_SKIN * np.sqrt(skin), rel=1e-9)
    assert result.stats["offset"] < 0.9 * OFFSET_SHARE * size_of(body)


@pytest.mark.parametrize("shape", ["ball", "box", "sheet"])
def test_compact_bodies_keep_their_boxs_size(shape):
    """A ball, a box and a flat sheet span less than a standing figure of their skin: their box's."""
    mesh = {"ball": trimesh.creation.icosphere(subdivisions=3, radius=0.4),
            "box": trimesh.creation.box(extents=(0.5, 0.7, 0.3)),
            "sheet": trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], [[0, 1, 2], [0, 2, 3]])}[shape]
    assert _size(mesh.vertices, mesh.faces) == pytest.approx(size_of(mesh.vertices), rel=1e-12)


def test_a_long_thin_body_takes_its_skins_size():
    """A rod 2 m long and 5 cm thick spans more than a standing figure of its skin: the skin's size."""
    rod = trimesh.creation.cylinder(radius=0.025, height=2.0, sections=24)
    expected = STANDING_SIZE_PER_SKIN * np.sqrt(rod.area)
    assert expected < 0.5 * size_of(rod.vertices)
    assert _size(rod.vertices, rod.faces) == pytest.approx(expected, rel=1e-9)


def test_a_body_of_flat_triangles_keeps_its_box():
    """Triangles of no area (each a line) have no skin to measure: the box's size, not zero."""
    v = np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0], [0, 1, 0], [0, 2, 0]])
    f = np.array([[0, 1, 2], [0, 3, 4]])
    assert _size(v, f) == pytest.approx(size_of(v), rel=1e-12) and size_of(v) > 0


def test_the_area_comes_with_the_normals():
    """vertex_normals_and_area: the normals vertex_normals gives, and trimesh's area of the mesh."""
    mesh = trimesh.creation.icosphere(subdivisions=2)
    rng = np.random.default_rng(4)
    v = mesh.vertices * rng.uniform(0.5, 2.0, size=(len(mesh.vertices), 1))
    normals, area = vertex_normals_and_area(v, mesh.faces)
    np.testing.assert_array_equal(normals, vertex_normals(v, mesh.faces))
    assert area == pytest.approx(trimesh.Trimesh(v, mesh.faces, process=False).area, rel=1e-12)
    assert vertex_normals_and_area(v[:0], mesh.faces[:0])[1] == 0.0
