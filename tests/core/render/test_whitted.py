"""Whitted shading and layered ray tracing on scenes with analytic answers."""

import numpy as np
import pytest
import trimesh

from core.render.layered_trace import LayeredScene
from core.render.lighting import Light
from core.render.surfaces import Material, Surfaces
from core.render.whitted import RenderSettings, camera_rays, render
from tests.core.layered_cases import sheet


def slab(thickness, size=4.0, z0=0.0):
    """A closed box from z0 - thickness to z0, faces outward."""
    box = trimesh.creation.box(extents=[size, size, thickness])
    box.apply_translation([0, 0, z0 - thickness / 2])
    return box.vertices, box.faces


def down_rays(n=5, z=1.0, spread=0.2):
    """Rays straight down (-z) from a small grid above the origin."""
    s = np.linspace(-spread, spread, n)
    x, y = np.meshgrid(s, s)
    o = np.column_stack([x.ravel(), y.ravel(), np.full(x.size, z)])
    return o, np.tile([0.0, 0.0, -1.0], (len(o), 1))


def test_lambert_sphere_under_a_sun():
    sphere = trimesh.creation.icosphere(subdivisions=5, radius=1.0)
    scene = LayeredScene([(sphere.vertices, sphere.faces)], [None])
    sun = Light("SUN", (0.3, -0.2, -1.0), (2.0, 2.0, 2.0))
    cam = np.eye(4)
    cam[:3, 3] = (0, 0, 5)
    o, d = camera_rays(cam, np.radians(30), 48, 48)
    img = render(scene, [Material(colour=(0.5, 0.4, 0.3))], [sun], o, d)
    covered = img.index == 0
    assert covered.sum() > 500
    p = o[covered] + d[covered] * img.depth[covered, None]
    # the exact sphere: normal = p / |p|; Lambert E albedo max(0, n.l); no shadow on a convex body
    to_sun = -np.array(sun.vector) / np.linalg.norm(sun.vector)
    normal = p / np.linalg.norm(p, axis=1, keepdims=True)
    expect = 2.0 * np.array([0.5, 0.4, 0.3]) * np.maximum(0.0, normal @ to_sun)[:, None]
    np.testing.assert_allclose(img.colour[covered], expect, atol=0.01)
    np.testing.assert_array_equal(img.colour[~covered], 0.0)


def test_blinn_phong_highlight_on_a_floor_seen_from_above():
    """Eq. 2.7-2.8 on a flat floor under a slanted sun, seen straight down: irradiance E times
    albedo cos(theta) plus k_s (n . h)^s with h halfway between the light and the eye; without
    k_s the diffuse term alone."""
    v, f = sheet(size=2.0, n=5, z=0.0)
    scene = LayeredScene([(v, f)], [None])
    sun_dir = np.array([0.4, -0.2, -1.0])
    sun = [Light("SUN", tuple(sun_dir), (1.5, 1.5, 1.5))]
    o, d = down_rays(n=4, spread=0.5)
    to_light = -sun_dir / np.linalg.norm(sun_dir)
    half = to_light + [0.0, 0.0, 1.0]
    half /= np.linalg.norm(half)
    albedo = np.array([0.6, 0.5, 0.4])
    for ks, shine in ((0.0, 32.0), (0.7, 20.0)):
        mats = [Material(colour=tuple(albedo), specular=ks, shininess=shine)]
        img = render(scene, mats, sun, o, d)
        want = 1.5 * (albedo * to_light[2] + ks * half[2] ** shine)
        np.testing.assert_allclose(img.colour, np.tile(want, (len(o), 1)), rtol=1e-9)


def test_a_coarse_smooth_sphere_does_not_shadow_itself():
    """A convex body casts no shadow on itself: on a 320-triangle sphere, smooth shading must
    give E albedo max(0, n_s.l) with n_s the interpolated vertex normal everywhere, also near
    the terminator, where the flat triangles would shadow the smoothly lit points (the shadow
    terminator problem: 48 pixels here without the offset shadow origins)."""
    sphere = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
    scene = LayeredScene([(sphere.vertices, sphere.faces)], [None])
    to_sun = np.array([1.0, 0.0, 0.35]) / np.linalg.norm([1.0, 0.0, 0.35])
    cam = np.eye(4)
    cam[:3, 3] = (0, 0, 5)
    o, d = camera_rays(cam, np.radians(30), 64, 64)
    img = render(scene, [Material(colour=(1, 1, 1))], [Light("SUN", tuple(-to_sun), (1, 1, 1))], o, d)
    hit = img.index == 0
    vis = scene.first_visible(o[hit], d[hit])
    n = scene.shading_normals[0][sphere.faces[vis.face]]  # the vertex normals it shades with
    u, v = vis.bary[:, :1], vis.bary[:, 1:]
    smooth = (1 - u - v) * n[:, 0] + u * n[:, 1] + v * n[:, 2]
    smooth /= np.linalg.norm(smooth, axis=1, keepdims=True)
    np.testing.assert_allclose(img.colour[hit, 0], np.maximum(0.0, smooth @ to_sun), atol=1e-9)


def test_glass_slab_transmits_what_fresnel_leaves_with_every_internal_bounce():
    """Normal incidence on glass (n = 1.5), a sky only below: T = (1-R)/(1+R) summed over bounces."""
    v, f = slab(0.1)
    scene = LayeredScene([(v, f)], [None])
    o, d = down_rays()
    below = lambda dirs: np.where(dirs[:, 2:3] < 0, 1.0, 0.0) * np.ones(3)  # noqa: E731
    r = ((1.5 - 1) / (1.5 + 1)) ** 2
    glass = [Material(colour=(0, 0, 0), transmission=1.0, ior=1.5)]
    img = render(scene, glass, [], o, d, RenderSettings(background=below, max_depth=12, cutoff=0.0))
    np.testing.assert_allclose(img.colour, (1 - r) / (1 + r), rtol=1e-6)
    # two bounces allowed: in and out only, (1 - R)^2
    img = render(scene, glass, [], o, d, RenderSettings(background=below, max_depth=2, cutoff=0.0))
    np.testing.assert_allclose(img.colour, (1 - r) ** 2, rtol=1e-6)


def test_beer_lambert_through_a_known_thickness():
    thickness, sigma = 0.25, np.array([0.5, 2.0, 8.0])
    v, f = slab(thickness)
    scene = LayeredScene([(v, f)], [None])
    o, d = down_rays()
    img = render(scene, [Material(transmission=1.0, ior=1.0, absorption=tuple(sigma))], [], o, d,
                 RenderSettings(background=(1.0, 1.0, 1.0), cutoff=0.0))
    np.testing.assert_allclose(img.colour, np.exp(-sigma * thickness)[None, :].repeat(len(o), 0), rtol=1e-6)


def test_mirror_recursion_stops_at_the_limit_and_at_the_importance_cutoff():
    """A ray between two facing mirrors bounces until max_depth, or until what it carries is
    under the cutoff: 0.5^k < 0.1 first at k = 4."""
    lower, upper = slab(0.1, z0=0.0), slab(0.1, z0=1.1)
    scene = LayeredScene([lower, upper], [None, None])
    o, d = down_rays(n=1, z=0.5)
    full = Material(colour=(0, 0, 0), mirror=1.0)
    img = render(scene, [full, full], [], o, d, RenderSettings(max_depth=7, cutoff=0.0, background=(1, 1, 1)))
    assert img.stats["deepest"] == 7 and img.stats["rays"] == 8
    np.testing.assert_allclose(img.colour, 0.0)  # never escapes
    half = Material(colour=(0, 0, 0), mirror=0.5)
    img = render(scene, [half, half], [], o, d, RenderSettings(max_depth=50, cutoff=0.1))
    assert img.stats["deepest"] == 3 and img.stats["cut_by_importance"] == 1


def test_clipping_cuts_what_camera_rays_see_and_not_what_they_reflect():
    """Three sheets under rays from z = 1: at 0.95 (nearer than the near clip, 0.1), at 0.5 and at
    -2 (past the far clip, 2). The rays see the middle one only, at depth 0.5 from the origins.
    A camera's clipping cuts camera rays only, as in Cycles: made a mirror, the middle sheet shows
    the sheet above it, nearer than the near clip and, along the bounced path, past a far clip at
    0.6. With the near clip at 0.01 the rays see the first sheet; between 0.1 and 0.4, nothing."""
    sheets = [sheet(size=2.0, n=4, z=z) for z in (0.95, 0.5, -2.0)]
    scene = LayeredScene(sheets, [None] * 3)
    o, d = down_rays(n=3)
    colours = [Material(colour=c) for c in ((1, 0, 0), (0, 1, 0), (0, 0, 1))]
    sun = [Light("SUN", (0, 0, -1), (1.0, 1.0, 1.0))]
    img = render(scene, colours, sun, o, d, RenderSettings(clip=(0.1, 2.0)))
    np.testing.assert_array_equal(img.index, 1)
    np.testing.assert_allclose(img.depth, 0.5)
    mirror = [colours[0], Material(colour=(0, 0, 0), mirror=1.0), colours[2]]
    img = render(scene, mirror, [], o, d, RenderSettings(clip=(0.1, 0.6), ambient=0.5))
    np.testing.assert_array_equal(img.index, 1)
    np.testing.assert_allclose(img.colour, np.tile([0.5, 0.0, 0.0], (len(o), 1)))  # the red sheet's ambient
    img = render(scene, colours, sun, o, d, RenderSettings(clip=(0.01, 2.0)))
    np.testing.assert_array_equal(img.index, 0)
    np.testing.assert_allclose(img.depth, 0.05)
    img = render(scene, colours, sun, o, d, RenderSettings(clip=(0.1, 0.4), background=(0.2, 0.3, 0.4)))
    np.testing.assert_array_equal(img.index, -1)
    assert np.isinf(img.depth).all()
    np.testing.assert_allclose(img.colour, np.tile([0.2, 0.3, 0.4], (len(o), 1)))
    with pytest.raises(ValueError, match="clip"):
        render(scene, colours, sun, o, d, RenderSettings(clip=(0.5, 0.5)))


def test_a_shifted_lens_moves_the_view_and_keeps_its_perspective():
    """Shifting by (sx, sy) on the image plane at distance 1 aims the middle of the frame along
    (sx, sy, -1), and every ray is the unshifted ray of the point sx, sy further on that plane."""
    o, d = camera_rays(np.eye(4), np.radians(40), 5, 3, shift=(0.3, -0.2))
    np.testing.assert_allclose(d[7], np.array([0.3, -0.2, -1.0]) / np.linalg.norm([0.3, -0.2, -1.0]))
    _, plain = camera_rays(np.eye(4), np.radians(40), 5, 3)
    on_plane = plain / -plain[:, 2:3] + [0.3, -0.2, 0.0]
    np.testing.assert_allclose(d, on_plane / np.linalg.norm(on_plane, axis=1, keepdims=True))
    np.testing.assert_array_equal(o, 0.0)


def test_orthographic_rays_are_parallel_from_the_camera_s_plane():
    """A camera turned to look along +x from (1, 2, 3): every ray runs along +x, from a grid of
    points on the camera's plane spanning the view's height (and its width by the aspect), shifted."""
    turn = np.array([[0.0, 0.0, -1.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])  # camera -z -> world +x
    m = np.eye(4)
    m[:3, :3], m[:3, 3] = turn, (1.0, 2.0, 3.0)
    o, d = camera_rays(m, None, 4, 2, shift=(0.5, -0.25), ortho_height=2.0)
    np.testing.assert_allclose(d, np.tile([1.0, 0.0, 0.0], (8, 1)), atol=1e-15)
    np.testing.assert_allclose(o[:, 0], 1.0)
    # pixel centres at x = -1.5 .. 1.5 (the width is twice the height), y = 0.5, -0.5; then shifted
    local_x = np.tile([-1.5, -0.5, 0.5, 1.5], 2) + 0.5
    local_y = np.repeat([0.5, -0.5], 4) - 0.25
    np.testing.assert_allclose(o[:, 1], 2.0 - local_x)
    np.testing.assert_allclose(o[:, 2], 3.0 + local_y)
    with pytest.raises(ValueError, match="orthographic"):
        camera_rays(m, None, 4, 2, ortho_height=0.0)


def test_an_object_unseen_by_the_camera_shows_what_is_behind_it_and_still_shadows_it():
    """Rays down through a sheet the camera does not see: they show the floor under it, with no
    pixel marked fixed, in the sheet's shadow (ambient only); a mirror floor still shows it."""
    over, floor = sheet(size=2.0, n=4, z=0.5), sheet(size=2.0, n=4, z=0.0)
    scene = LayeredScene([over, floor], [None, None])
    o, d = down_rays(n=3)
    mats = [Material(colour=(1, 0, 0)), Material(colour=(0, 1, 0))]
    sun = [Light("SUN", (0, 0, -1), (1.0, 1.0, 1.0))]
    img = render(scene, mats, sun, o, d, RenderSettings(ambient=0.5, unseen=[True, False]))
    np.testing.assert_array_equal(img.index, 1)
    np.testing.assert_allclose(img.depth, 1.0)
    np.testing.assert_allclose(img.colour, np.tile([0.0, 0.5, 0.0], (len(o), 1)))
    assert not img.fixed.any()
    vis = scene.first_visible(o, d, unseen=[True, False])
    np.testing.assert_array_equal(vis.obj, 1)
    assert vis.skipped == 0
    mirror = [mats[0], Material(colour=(0, 0, 0), mirror=1.0)]
    img = render(scene, mirror, [], o, d, RenderSettings(ambient=0.5, unseen=[True, False]))
    np.testing.assert_allclose(img.colour, np.tile([0.5, 0.0, 0.0], (len(o), 1)))  # the sheet, in the mirror


def test_objects_off_for_glossy_shadow_or_transmission_rays_are_passed_by_those_rays_only():
    """The sheet the camera does not see, over a mirror floor: with Glossy off it is gone from the
    mirror (the black world shows); with Shadow off a matte floor under it is lit by the sun; a
    glass floor seen through (Transmission off for the sheet under it) shows the world, not the sheet."""
    over, floor = sheet(size=2.0, n=4, z=0.5), sheet(size=2.0, n=4, z=0.0)
    scene = LayeredScene([over, floor], [None, None])
    o, d = down_rays(n=3)
    red = Material(colour=(1, 0, 0))
    mirror = [red, Material(colour=(0, 0, 0), mirror=1.0)]
    seen = render(scene, mirror, [], o, d, RenderSettings(ambient=0.5, unseen=[True, False]))
    gone = render(scene, mirror, [], o, d, RenderSettings(ambient=0.5, unseen=[True, False], unreflected=[True, False]))
    np.testing.assert_allclose(seen.colour, np.tile([0.5, 0.0, 0.0], (len(o), 1)))
    np.testing.assert_allclose(gone.colour, 0.0)
    sun = [Light("SUN", (0, 0, -1), (1.0, 1.0, 1.0))]
    matte = [red, Material(colour=(0, 1, 0))]
    shaded = render(scene, matte, sun, o, d, RenderSettings(unseen=[True, False]))
    lit = render(scene, matte, sun, o, d, RenderSettings(unseen=[True, False], shadowless=[True, False]))
    np.testing.assert_allclose(shaded.colour, 0.0)
    np.testing.assert_allclose(lit.colour, np.tile([0.0, 1.0, 0.0], (len(o), 1)), rtol=1e-9)  # albedo x E cos 0
    # from below the floor, looking up through a clear glass floor at the sheet over it
    up = o * [1, 1, -1], -d
    glass = [red, Material(colour=(1, 1, 1), transmission=1.0, ior=1.0)]
    through = render(scene, glass, [], *up, RenderSettings(ambient=0.5))
    cut = render(scene, glass, [], *up, RenderSettings(ambient=0.5, unrefracted=[True, False]))
    np.testing.assert_allclose(through.colour, np.tile([0.5, 0.0, 0.0], (len(o), 1)), atol=1e-9)
    np.testing.assert_allclose(cut.colour, 0.0, atol=1e-9)
    np.testing.assert_array_equal(cut.index, 1)  # the camera still sees the glass


def test_z_fighting_sheets_show_only_the_higher_layer():
    v, f = sheet(size=1.0, n=20, z=0.0)
    wiggle = v.copy()
    wiggle[:, 2] += 0.002 * np.sin(37 * v[:, 0]) * np.cos(23 * v[:, 1])  # each wins half the pixels
    up = np.tile([0.0, 0.0, 1.0], (len(v), 1))
    scene = LayeredScene([(wiggle, f), (v, f)], [1, 2], global_normals=[up, up], probe_distance=0.01)
    o, d = down_rays(n=30, spread=0.45)
    plain = scene.first_visible(o, d, layered=False)
    shown = scene.first_visible(o, d)
    assert 0.2 < (plain.obj == 0).mean() < 0.8  # plain ray tracing shows both, as they cross
    assert (shown.obj == 1).all()
    np.testing.assert_array_equal(shown.fixed, plain.obj == 0)
    # a lower layer 5 cm out, beyond the 1 cm probe, is not taken for poking through: it shows
    far = LayeredScene([(v + [0, 0, 0.05], f), (v, f)], [1, 2], global_normals=[up, up], probe_distance=0.01)
    assert (far.first_visible(o, d).obj == 0).all()
    near = LayeredScene([(v + [0, 0, 0.005], f), (v, f)], [1, 2], global_normals=[up, up], probe_distance=0.01)
    assert (near.first_visible(o, d).obj == 1).all()


def test_ten_crossing_layers_show_only_the_outermost_from_above():
    """Ten wavy sheets worn in order, each crossing the others (a stack of poke-throughs): from
    above only the tenth shows, wherever plain ray tracing shows one of the nine under it. Only
    the layers rays meet get a scene of what is worn over them, and each layer in those is
    built once for all of them."""
    layers = [sheet(size=1.0, n=24, z=0.002 * k, height_fn=lambda x, y, k=k: 0.006 * np.sin(7 * x + k) * np.cos(5 * y))
              for k in range(10)]
    up = [np.tile([0.0, 0.0, 1.0], (len(v), 1)) for v, _ in layers]
    scene = LayeredScene(layers, list(range(1, 11)), global_normals=up, probe_distance=0.05)
    o, d = down_rays(n=40, spread=0.45)
    plain = scene.first_visible(o, d, layered=False)
    shown = scene.first_visible(o, d)
    assert len(np.unique(plain.obj)) > 3  # plain ray tracing shows several of the lower ones
    assert (shown.obj == 9).all()
    np.testing.assert_array_equal(shown.fixed, plain.obj != 9)
    # covers only for the layers rays met, each layer over them built once for all of them
    assert sorted(scene._layer_scenes) == list(range(plain.obj.min() + 1, 10))
    assert len(scene.scene._groups) == 9 - plain.obj.min()


def test_rays_of_any_length_see_and_are_blocked_as_their_unit_rays():
    """Directions need not be of length one: ten crossing layers seen from above, and shadow
    rays leaving each of them, give the same answers for directions of lengths 0.1 to 10 as
    for unit ones, also where rays go on past several ignored hits (each round steps along the
    ray by the distance it found)."""
    layers = [sheet(size=1.0, n=24, z=0.002 * k, height_fn=lambda x, y, k=k: 0.006 * np.sin(7 * x + k) * np.cos(5 * y))
              for k in range(10)]
    up = [np.tile([0.0, 0.0, 1.0], (len(v), 1)) for v, _ in layers]
    scene = LayeredScene(layers, list(range(1, 11)), global_normals=up, probe_distance=0.05)
    o, d = down_rays(n=40, spread=0.45)
    rng = np.random.default_rng(5)
    length = 10.0 ** rng.uniform(-1, 1, len(d))
    ref, got = scene.first_visible(o, d), scene.first_visible(o, d * length[:, None])
    assert ref.skipped > ref.fixed.sum()  # some rays went on past more than one ignored hit
    np.testing.assert_array_equal(got.obj, ref.obj)
    np.testing.assert_array_equal(got.fixed, ref.fixed)
    np.testing.assert_allclose(got.t, ref.t, rtol=1e-9)
    # shadow rays from each layer, up and down through the stack
    n = 2000
    leaving = rng.integers(0, 10, n)
    start = np.column_stack([rng.uniform(-0.4, 0.4, (n, 2)), 0.002 * leaving])
    way = rng.normal(size=(n, 3))
    way /= np.linalg.norm(way, axis=1, keepdims=True)
    dist = rng.uniform(0.005, 1.0, n)
    ref = scene.blocked(start, way, dist, leaving=leaving)
    assert ref.any() and not ref.all()
    stretched = way * 10.0 ** rng.uniform(-1, 1, (n, 1))
    np.testing.assert_array_equal(scene.blocked(start, stretched, dist, leaving=leaving), ref)


@pytest.mark.parametrize("scale, offset", [(1e-3, 0.0), (1e3, 0.0), (1.0, 1e4), (1e-3, 50.0)])
def test_z_fighting_layers_resolve_the_same_at_millimetre_and_kilometre_scales_and_far_away(scale, offset):
    """The z-fighting sheets and, over their right half, a stack of four wavy layers crossing
    each other, scaled from a millimetre garment to a kilometre one and moved far from the
    origin (float32 tracing works about each scene's centre): the same layer shows at every ray
    as at human scale, and the same rays are fixed."""
    def scenes(k, shift):
        v, f = sheet(size=1.0, n=20, z=0.0)
        wiggle = v.copy()
        wiggle[:, 2] += 0.002 * np.sin(37 * v[:, 0]) * np.cos(23 * v[:, 1])
        layers = [(wiggle * k + shift, f), (v * k + shift, f)]
        for j in range(4):
            w, g = sheet(size=1.0, n=12, z=0.003 * j, height_fn=lambda x, y, j=j: 0.005 * np.sin(8 * x + j))
            layers.append(((w + [0.5, 0.0, 0.1]) * k + shift, g))  # over the right half
        up = [np.tile([0.0, 0.0, 1.0], (len(x), 1)) for x, _ in layers]
        return LayeredScene(layers, [1, 2, 3, 4, 5, 6], global_normals=up, probe_distance=0.01 * k)

    o, d = down_rays(n=30, spread=0.45)
    ref = scenes(1.0, 0.0).first_visible(o, d)
    shift = np.array([offset, -offset, offset])
    got = scenes(scale, shift).first_visible(o * scale + shift, d)
    # the higher of the z-fighting pair on the left, the outermost of the stack on the right
    np.testing.assert_array_equal(ref.obj, np.where(o[:, 0] < 0, 1, 5))
    np.testing.assert_array_equal(got.obj, ref.obj)
    np.testing.assert_array_equal(got.fixed, ref.fixed)
    np.testing.assert_allclose(got.t, ref.t * scale, rtol=1e-9)


def test_camera_rays_of_any_length_render_as_their_unit_rays():
    """A shiny, mirroring and partly transmissive sphere over two z-fighting sheets: camera
    directions of lengths 0.1 to 10 give the image of the unit ones (hit points, highlights and
    Fresnel all take the direction of length one)."""
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=0.3)
    v, f = sheet(size=2.0, n=20, z=0.0)
    wiggle = v.copy()
    wiggle[:, 2] += 0.002 * np.sin(37 * v[:, 0]) * np.cos(23 * v[:, 1])
    up = np.tile([0.0, 0.0, 1.0], (len(v), 1))
    scene = LayeredScene([(sphere.vertices + [0, 0, 0.5], sphere.faces), (wiggle, f), (v, f)], [None, 1, 2],
                         global_normals=[None, up, up], probe_distance=0.01)
    mats = [Material(colour=(0.9, 0.2, 0.1), specular=0.5, mirror=0.3, transmission=0.4, ior=1.4),
            Material(colour=(1, 0, 0)), Material(colour=(0, 0, 1))]
    sun = [Light("SUN", (-0.3, -0.2, -1.0), (1, 1, 1))]
    o, d = down_rays(n=24, z=2.0, spread=0.8)
    length = 10.0 ** np.random.default_rng(2).uniform(-1, 1, (len(d), 1))
    ref, got = render(scene, mats, sun, o, d), render(scene, mats, sun, o, d * length)
    assert (ref.index == 0).any() and (ref.index == 2).any() and ref.fixed.any()
    np.testing.assert_array_equal(got.index, ref.index)
    np.testing.assert_allclose(got.colour, ref.colour, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(got.depth[np.isfinite(ref.depth)], ref.depth[np.isfinite(ref.depth)], rtol=1e-9)


def test_flipped_faces_shade_the_same():
    sphere = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    sun = [Light("SUN", (0, 0, -1), (1, 1, 1))]
    o, d = down_rays(n=7, z=3.0, spread=0.6)
    a = render(LayeredScene([(sphere.vertices, sphere.faces)], [None]), [Material()], sun, o, d)
    b = render(LayeredScene([(sphere.vertices, sphere.faces[:, ::-1])], [None]), [Material()], sun, o, d)
    np.testing.assert_allclose(a.colour, b.colour, atol=1e-9)


def test_point_light_falls_off_with_the_square_of_distance():
    v, f = sheet(size=4.0, n=9, z=0.0)
    scene = LayeredScene([(v, f)], [None])
    o, d = down_rays(n=1)
    near = render(scene, [Material(colour=(1, 1, 1))], [Light("POINT", (0, 0, 1.0), (4, 4, 4))], o, d)
    far = render(scene, [Material(colour=(1, 1, 1))], [Light("POINT", (0, 0, 2.0), (4, 4, 4))], o, d)
    for img, height in ((near, 1.0), (far, 2.0)):
        r2 = height**2 + (o[0, :2] ** 2).sum()  # the ray lands at (x, y, 0) under a light at (0, 0, h)
        np.testing.assert_allclose(img.colour, 4.0 * (height / np.sqrt(r2)) / r2, rtol=1e-9)


@pytest.mark.parametrize("blend", [0.0, 0.4, 1.0])
def test_spot_light_is_a_point_light_inside_its_cone_with_a_smoothstep_edge(blend):
    """A spot 1 m over a white floor, pointing down, cone edge at 0.5 m from its foot: E = I cos / r^2
    times Blender's edge mask smoothstep((cos a - cos(size/2)) / ((1 - cos(size/2)) blend)), a the
    angle off the axis (here the same as the angle of incidence); a hard edge when blend is 0."""
    v, f = sheet(size=4.0, n=9, z=0.0)
    scene = LayeredScene([(v, f)], [None])
    o, d = down_rays(n=41, z=1.0, spread=0.8)
    size = 2 * np.arctan(0.5)
    spot = Light("SPOT", (0, 0, 1.0), (4, 4, 4), axis=(0, 0, -2.0), spot_size=size, spot_blend=blend)
    img = render(scene, [Material(colour=(1, 1, 1))], [spot], o, d)
    r2 = 1.0 + (o[:, :2] ** 2).sum(1)
    cos = 1.0 / np.sqrt(r2)
    cos_half = np.cos(size / 2)
    if blend == 0:
        mask = (cos > cos_half).astype(float)
    else:
        x = np.clip((cos - cos_half) / ((1 - cos_half) * blend), 0, 1)
        mask = x * x * (3 - 2 * x)
    np.testing.assert_allclose(img.colour, (4.0 * cos / r2 * mask)[:, None].repeat(3, 1), rtol=1e-9, atol=1e-15)
    lit = img.colour[:, 0]
    assert (lit == 0).any() and (lit > 0).any()  # the cone's edge is inside the picture
    if blend > 0:  # and its ramp
        assert ((mask > 0.05) & (mask < 0.95)).any()
    # a point light of the same intensity: the same inside the cone, away from its edge
    inside = mask == 1
    point = render(scene, [Material(colour=(1, 1, 1))], [Light("POINT", (0, 0, 1.0), (4, 4, 4))], o, d)
    np.testing.assert_allclose(img.colour[inside], point.colour[inside], rtol=1e-12)


def test_square_area_light_gives_the_view_factor_irradiance():
    """A Lambertian square of side 1 at 1 m over a white floor: E = pi L F, F from the
    parallel-rectangle view factor (Howell's catalogue B-3) summed over four corner quarters."""
    v, f = sheet(size=4.0, n=9, z=0.0)
    scene = LayeredScene([(v, f)], [None])
    o, d = down_rays(n=1)
    o[:, :2] = 0.0
    intensity = 3.0  # along the normal: P / pi
    light = Light("AREA", (0, 0, 1.0), (intensity,) * 3, edges=((0.5, 0, 0), (0, -0.5, 0)), samples=32)
    img = render(scene, [Material(colour=(1, 1, 1))], [light], o, d)
    x = y = 0.5 / 1.0
    corner = (x / np.sqrt(1 + x**2) * np.arctan(y / np.sqrt(1 + x**2))
              + y / np.sqrt(1 + y**2) * np.arctan(x / np.sqrt(1 + y**2))) / (2 * np.pi)
    radiance = intensity / 1.0  # I / area
    np.testing.assert_allclose(img.colour, np.pi * radiance * 4 * corner, rtol=2e-3)
    # off to the side (a point outside the light's footprint): the rectangle's view factor by
    # superposition of corner rectangles, G(x, y) = sign(x) sign(y) f(|x|, |y|)
    def f(x, y):
        return (x / np.sqrt(1 + x**2) * np.arctan(y / np.sqrt(1 + x**2))
                + y / np.sqrt(1 + y**2) * np.arctan(x / np.sqrt(1 + y**2))) / (2 * np.pi)

    def g(x, y):
        return np.sign(x) * np.sign(y) * f(abs(x), abs(y))

    px, py = 0.8, 0.3
    x1, x2, y1, y2 = -0.5 - px, 0.5 - px, -0.5 - py, 0.5 - py
    side = g(x2, y2) - g(x1, y2) - g(x2, y1) + g(x1, y1)
    o[:, :2] = (px, py)
    img = render(scene, [Material(colour=(1, 1, 1))], [light], o, d)
    np.testing.assert_allclose(img.colour, np.pi * radiance * side, rtol=2e-3)
    # it lights one side only: flipped (u x v pointing up) the floor gets nothing
    dark = Light("AREA", (0, 0, 1.0), (intensity,) * 3, edges=((0.5, 0, 0), (0, 0.5, 0)), samples=4, disk=True)
    np.testing.assert_array_equal(render(scene, [Material(colour=(1, 1, 1))], [dark], o, d).colour, 0.0)


def test_a_covered_lower_layer_casts_no_shadow_on_the_layer_over_it():
    v, f = sheet(size=1.0, n=20, z=0.0)
    wiggle = v.copy()
    wiggle[:, 2] += 0.002 * np.sin(37 * v[:, 0]) * np.cos(23 * v[:, 1])
    up = np.tile([0.0, 0.0, 1.0], (len(v), 1))
    scene = LayeredScene([(wiggle, f), (v, f)], [1, 2], global_normals=[up, up], probe_distance=0.01)
    o, d = down_rays(n=30, spread=0.45)
    mats = [Material(colour=(1, 0, 0)), Material(colour=(0, 0, 1))]
    sun = [Light("SUN", (0.1, 0.0, -1.0), (1, 1, 1))]
    img = render(scene, mats, sun, o, d)
    assert img.fixed.any()
    # the outer sheet everywhere, lit as if the inner one were not there
    np.testing.assert_allclose(img.colour, np.tile([0, 0, 1 / np.sqrt(1.01)], (len(o), 1)), rtol=1e-6)


@pytest.mark.parametrize("settle_early", [True, False])
def test_a_stack_of_layers_shadows_the_floor_under_it_and_nothing_beside_it(settle_early, monkeypatch):
    """Four wavy sheets crossing each other over a floor (the body): a shadow ray going up from
    under the stack meets the outermost sheet, so it is blocked however the covered sheets in
    between are decided; beside the stack nothing blocks. With enough rays the outermost sheet
    settles them with one occlusion ray each; without, they go round the layered loop; the
    answers are the same."""
    floor, ff = sheet(size=3.0, n=4, z=-0.1)
    layers = []
    for k in range(4):
        v, f = sheet(size=1.0, n=8, z=0.004 * k, height_fn=lambda x, y, k=k: 0.006 * np.sin(9 * x + k) * np.cos(7 * y))
        layers.append((v, f))
    up = [np.tile([0.0, 0.0, 1.0], (len(v), 1)) for v, _ in [(floor, ff), *layers]]
    scene = LayeredScene([(floor, ff), *layers], [0, 1, 2, 3, 4], global_normals=up, probe_distance=0.02)
    if not settle_early:
        monkeypatch.setattr(LayeredScene, "_uncovered_scene", lambda self, rays: None)
    xy = np.random.default_rng(3).uniform(-1.4, 1.4, (2000, 2))
    o = np.column_stack([xy, np.full(len(xy), -0.09)])  # just over the floor
    d = np.tile([0.0, 0.0, 1.0], (len(o), 1))
    blocked = scene.blocked(o, d, np.full(len(o), 10.0), leaving=np.zeros(len(o), int))
    under = (np.abs(xy) < 0.49).all(1)
    beside = (np.abs(xy) > 0.51).any(1)
    assert blocked[under].all() and not blocked[beside].any()
    assert (scene._uncovered not in (None, False)) == settle_early  # the outermost sheet's scene was used


def test_shadow_rays_settled_past_poke_throughs_agree_with_stepping_hit_by_hit():
    """Sheets crossing each other, so each pokes through the ones over it by up to 6 mm, with
    probe distances of 1-3 cm varying over each sheet: shadow rays in every direction from
    every layer. Two occlusion rays (nothing as high as the ray's own layer on the way, nothing
    past the shortest probe distance of the layers under it) settle many of them; the rest,
    and every ray when that is turned off, step past each poke-through with a closest hit at
    a time. The answers must be the same ray for ray."""
    floor, ff = sheet(size=3.0, n=4, z=-0.1)
    objects, normals, probes = [(floor, ff)], [np.tile([0.0, 0.0, 1.0], (len(floor), 1))], [np.full(len(floor), 0.02)]
    for k in range(4):
        v, f = sheet(size=1.0, n=12, z=0.003 * k, height_fn=lambda x, y, k=k: 0.006 * np.sin(9 * x + k) * np.cos(7 * y))
        objects.append((v, f))
        normals.append(np.tile([0.0, 0.0, 1.0], (len(v), 1)))
        probes.append(0.02 + 0.01 * np.sin(5 * v[:, 0] + k))
    scene = LayeredScene(objects, [0, 1, 2, 3, 4], global_normals=normals, probe_distance=probes)
    rng = np.random.default_rng(11)
    n = 3000
    leaving = rng.integers(0, 5, n)
    o = np.column_stack([rng.uniform(-0.6, 0.6, (n, 2)), 0.003 * leaving + rng.uniform(-0.008, 0.008, n)])
    d = rng.normal(size=(n, 3))
    d[:, 2] = np.abs(d[:, 2]) * np.where(rng.random(n) < 0.8, 1.0, -1.0)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    dist = rng.uniform(0.005, 2.0, n)
    settled = scene.blocked(o, d, dist, leaving=leaving)
    free = scene._clear_past_pokes(o, d, dist, scene.object_layer[leaving])
    stepped = LayeredScene(objects, [0, 1, 2, 3, 4], global_normals=normals, probe_distance=probes)
    stepped._clear_past_pokes = lambda o, d, dist, own: np.zeros(len(o), bool)
    np.testing.assert_array_equal(settled, stepped.blocked(o, d, dist, leaving=leaving))
    assert free.sum() > n // 10 and settled.any() and not settled.all()  # both ways were taken


def test_a_lower_layer_poking_out_within_the_probe_distance_casts_no_shadow():
    """A patch of the lower layer lies 5 mm over the outer sheet, its global normals sideways, so
    its own probe misses the sheet and the camera sees it. Beside it the outer sheet is shown,
    and a slanted sun's shadow ray from there meets the patch 7 mm away, within the 1 cm probe:
    a poke-through, so the sheet is lit. Plain tracing shadows it."""
    v, f = sheet(size=1.0, n=11, z=0.0)
    pv, pf = sheet(size=0.2, n=5, z=0.005)
    scene = LayeredScene([(pv, pf), (v, f)], [1, 2], probe_distance=0.01,
                         global_normals=[np.tile([1.0, 0.0, 0.0], (len(pv), 1)), np.tile([0.0, 0.0, 1.0], (len(v), 1))])
    o = np.column_stack([np.full(5, -0.103), np.linspace(-0.05, 0.05, 5), np.full(5, 1.0)])
    d = np.tile([0.0, 0.0, -1.0], (5, 1))
    sun = [Light("SUN", (-1.0, 0.0, -1.0), (1, 1, 1))]
    mats = [Material(colour=(1, 0, 0)), Material(colour=(0, 0, 1))]
    img = render(scene, mats, sun, o, d)
    assert (img.index == 1).all()
    np.testing.assert_allclose(img.colour, np.tile([0, 0, np.sqrt(0.5)], (5, 1)), rtol=1e-9)
    np.testing.assert_array_equal(render(scene, mats, sun, o, d, RenderSettings(layered=False)).colour, 0.0)


def test_probe_distance_per_vertex_follows_the_body_under_each_garment():
    """A lower layer 3 cm out of the one worn over it is a poke-through for a 5 cm probe (a
    torso) but not for a 1 cm one (a wrist, where 5 cm would reach the far side): the probe
    distance can be given per vertex, blended at each hit."""
    v, f = sheet(size=1.0, n=11, z=0.0)
    up = np.tile([0.0, 0.0, 1.0], (len(v), 1))
    objects = [(v + [0, 0, 0.03], f), (v, f)]
    o, d = down_rays(n=5, spread=0.3)
    torso = LayeredScene(objects, [1, 2], global_normals=[up, up], probe_distance=0.05)
    assert (torso.first_visible(o, d).obj == 1).all()
    ramp = 0.01 + 0.04 * (v[:, 0] > 0)  # 1 cm on the left half, 5 cm on the right
    mixed = LayeredScene(objects, [1, 2], global_normals=[up, up], probe_distance=[ramp, None])
    shown = mixed.first_visible(o, d).obj
    left, right = o[:, 0] < -0.1, o[:, 0] > 0.1
    assert (shown[left] == 0).all() and (shown[right] == 1).all()
    with pytest.raises(ValueError, match="one per vertex"):
        LayeredScene(objects, [1, 2], probe_distance=[ramp[:-1], None])


@pytest.mark.parametrize("bad, match", [
    (dict(materials=[]), "materials"),
    (dict(max_depth=-1), "max_depth"),
    (dict(lights=[Light("SPOTLIGHT", (0, 0, 1))]), "SUN, POINT, SPOT or AREA"),
    (dict(lights=[Light("SPOT", (0, 0, 1), spot_size=0.0)]), "spot_size"),
    (dict(lights=[Light("SPOT", (0, 0, 1), spot_blend=1.5)]), "spot_blend"),
    (dict(lights=[Light("SPOT", (0, 0, 1), axis=(0, 0, 0))]), "axis"),
])
def test_bad_input_is_refused(bad, match):
    v, f = sheet(size=1.0, n=4)
    scene = LayeredScene([(v, f)], [None])
    o, d = down_rays(n=1)
    args = dict(materials=[Material()], lights=[Light("SUN", (0, 0, -1))], max_depth=2) | bad
    with pytest.raises(ValueError, match=match):
        render(scene, args["materials"], args["lights"], o, d, RenderSettings(max_depth=args["max_depth"]))
    with pytest.raises(ValueError, match="field of view"):
        camera_rays(np.eye(4), 0.0, 4, 4)
    with pytest.raises(ValueError, match="layers"):
        LayeredScene([(v, f)], [None, 1])


def test_faces_take_their_slots_material_and_bad_slots_are_refused():
    """One sheet, its faces in two slots by x: each pixel shows its face's slot's Lambert colour."""
    v, f = sheet(size=1.0, n=6)
    scene = LayeredScene([(v, f)], [None])
    o, d = down_rays(n=9, spread=0.4)
    slot = (v[f].mean(1)[:, 0] > 0).astype(int)
    red, green = Material(colour=(0.9, 0.1, 0.1)), Material(colour=(0.1, 0.8, 0.2))
    sun = [Light("SUN", (0, 0, -1), (1, 1, 1))]
    img = render(scene, Surfaces.build(scene, [[red, green]], face_slots=[slot]), sun, o, d)
    on = slot[scene.first_visible(o, d).face]  # the slot of the face each ray meets
    np.testing.assert_allclose(img.colour, np.where((on == 1)[:, None], green.colour, red.colour), rtol=1e-12)
    assert 0 < on.mean() < 1
    # without slots the first material everywhere, as a lone Material
    lone = render(scene, [red], sun, o, d).colour
    np.testing.assert_array_equal(render(scene, [[red, green]], sun, o, d).colour, lone)
    for bad, match in (([slot[:-1]], "one slot per face"), ([slot, slot], "one entry per object")):
        with pytest.raises(ValueError, match=match):
            render(scene, Surfaces.build(scene, [[red, green]], face_slots=bad), sun, o, d)
    with pytest.raises(ValueError, match="non-empty list"):
        render(scene, [[]], sun, o, d)


def test_a_texture_is_read_at_the_hits_uv_bilinear_and_repeating():
    """A 2 x 2 texture over a unit sheet (UV = position + 0.5): at texel centres each texel's own
    colour, between two centres their mean, and past the sheet's UV range the texture repeats;
    under a sun straight above a Lambert surface shows its albedo."""
    v, f = sheet(size=1.0, n=4)
    scene = LayeredScene([(v, f)], [None])
    texels = np.array([[[1.0, 0, 0], [0, 1.0, 0]], [[0, 0, 1.0], [1.0, 1.0, 1.0]]])  # row 0 at v = 0
    cloth = Material(colour=(0.5, 0.5, 0.5), texture=texels)
    sun = [Light("SUN", (0, 0, -1), (1, 1, 1))]
    at = np.array([[0.25, 0.25], [0.75, 0.25], [0.25, 0.75], [0.75, 0.75], [0.5, 0.25], [0.5, 0.5]])
    o = np.column_stack([at - 0.5, np.ones(len(at))])
    d = np.tile([0.0, 0.0, -1.0], (len(o), 1))
    uv = v[f][..., :2] + 0.5
    img = render(scene, Surfaces.build(scene, [cloth], face_uvs=[uv]), sun, o, d)  # barycentrics come in float32: 1e-6
    want = [texels[0, 0], texels[0, 1], texels[1, 0], texels[1, 1], texels[0].mean(0), texels.mean((0, 1))]
    np.testing.assert_allclose(img.colour, want, atol=1e-6)
    # whole repeats: the same
    shifted = render(scene, Surfaces.build(scene, [cloth], face_uvs=[uv + [3.0, -2.0]]), sun, o, d)
    np.testing.assert_allclose(shifted.colour, want, atol=1e-6)
    # no UVs given: every hit at UV (0, 0), the mean of the four corners' texels there
    np.testing.assert_allclose(render(scene, [cloth], sun, o, d).colour, np.tile(texels.mean((0, 1)), (len(o), 1)),
                               atol=1e-6)
    with pytest.raises(ValueError, match="texture"):
        render(scene, [Material(texture=np.zeros((2, 2)))], sun, o, d)
    with pytest.raises(ValueError, match="face_uvs"):
        render(scene, Surfaces.build(scene, [cloth], face_uvs=[uv[:-1]]), sun, o, d)


def test_flat_corner_normals_shade_each_face_by_its_own_normal():
    """A coarse sphere with every face's corners given its face normal (flat shading): under a
    sun each pixel is the Lambert term of the face it meets, where smooth vertex normals vary."""
    sphere = trimesh.creation.icosphere(subdivisions=1, radius=1.0)
    scene = LayeredScene([(sphere.vertices, sphere.faces)], [None])
    flat = np.repeat(sphere.face_normals[:, None, :], 3, axis=1)
    to_sun = np.array([0.3, 0.2, 1.0]) / np.linalg.norm([0.3, 0.2, 1.0])
    sun = [Light("SUN", tuple(-to_sun), (1, 1, 1))]
    o, d = down_rays(n=15, z=3.0, spread=0.7)
    img = render(scene, Surfaces.build(scene, [Material(colour=(1, 1, 1))], corner_normals=[flat]), sun, o, d)
    face = scene.first_visible(o, d).face
    lit = np.maximum(0.0, sphere.face_normals[face] @ to_sun)
    shown = img.index >= 0
    assert shown.sum() > 100
    np.testing.assert_allclose(img.colour[shown], np.repeat(lit[shown, None], 3, 1), atol=1e-9)
    smooth = render(scene, [Material(colour=(1, 1, 1))], sun, o, d)
    assert np.abs(smooth.colour[shown] - img.colour[shown]).max() > 0.05
    with pytest.raises(ValueError, match="corner_normals"):
        render(scene, Surfaces.build(scene, [Material()], corner_normals=[flat[:-1]]), sun, o, d)


def _exact_fresnel(cos_i, n1, n2):
    """Unpolarised reflectance from the Fresnel equations (the average of s and p)."""
    sin_t = n1 / n2 * np.sqrt(np.maximum(0.0, 1 - cos_i**2))
    if sin_t >= 1:
        return 1.0
    cos_t = np.sqrt(1 - sin_t**2)
    rs = ((n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t)) ** 2
    rp = ((n1 * cos_t - n2 * cos_i) / (n1 * cos_t + n2 * cos_i)) ** 2
    return 0.5 * (rs + rp)


@pytest.mark.parametrize("ior", [1.33, 1.5, 2.4])
def test_fresnel_follows_the_fresnel_equations_and_reflects_all_past_the_critical_angle(ior):
    """Against the exact (unpolarised) reflectance: equal at normal incidence, within Schlick's own
    error at oblique angles for water (a wrong power or cosine passes at normal incidence only),
    rising to all of it at the critical angle from inside and staying there past it; Snell's law
    for the refracted ray."""
    from core.render.whitted import fresnel

    angles = np.radians(np.arange(0.0, 89.5, 0.5))
    cos_i = np.cos(angles)
    for entering in (True, False):
        n1, n2 = (1.0, ior) if entering else (ior, 1.0)
        eta, cos_t, got = fresnel(cos_i, np.full_like(cos_i, ior), np.full(len(cos_i), entering))
        want = np.array([_exact_fresnel(c, n1, n2) for c in cos_i])
        assert got[0] == pytest.approx(want[0], abs=1e-12)
        critical = np.arcsin(1 / ior) if not entering else np.pi / 2
        np.testing.assert_array_equal(got[angles > critical + 1e-9], 1.0)
        ok = angles < critical - 1e-9  # Snell: n1 sin i = n2 sin t
        np.testing.assert_allclose(n1 * np.sin(angles[ok]), n2 * np.sqrt(1 - cos_t[ok] ** 2), atol=1e-12)
        if not entering:  # no jump into total reflection: just short of it, nearly all is reflected
            just = np.cos([critical - 1e-5])
            assert fresnel(just, np.array([ior]), np.array([False]))[2][0] > 0.95
        if ior == 1.33:
            near = angles < (np.radians(60) if entering else 0.85 * critical)
            assert np.abs(got - want)[near].max() < 0.012
