"""Whitted-style shading (thesis 2.4) over a LayeredScene: Blinn-Phong with shadow rays
(eq. 2.7-2.8), mirror reflection with a recursion limit and an importance cutoff on the NTSC
luminance of what a ray still carries (2.9-2.11), refraction by Snell with Schlick's Fresnel
(2.12-2.13) and Beer-Lambert attenuation inside transmissive objects (2.14).

Rays travel in batches; each carries the pixel it adds to and the share ("weight") of that
pixel it decides, so a reflection or refraction is one more batch, not a recursive call.
"""

from dataclasses import dataclass, field

import numpy as np

from ..geometry.vectors import norms, rows
from ..rays.scene import unit_rays
from .layered_trace import LayeredScene, Visible
from .lighting import LitPoints, Shading, direct_light
from .surfaces import SurfaceHits, Surfaces, bilinear, corner_blend, shading_normal, shadow_origin

LUMA = np.array([0.299, 0.587, 0.114])  # NTSC luminance weights


@dataclass
class Image:
    colour: np.ndarray  # (n, 3)
    depth: np.ndarray  # first visible hit distance (inf: background)
    index: np.ndarray  # object index of the first visible hit (-1: background)
    fixed: np.ndarray  # where layered tracing changed the first hit
    stats: dict = field(default_factory=dict)


def fresnel(cos_i, ior, entering):
    """(eta, cos of the refracted angle, reflected share) of light meeting a surface of index
    ``ior`` at cos ``cos_i`` (eq. 2.12-2.13), from outside where ``entering``: Schlick's
    approximation on the side of the lower index, and all of it reflected past the critical angle."""
    eta = np.where(entering, 1.0 / ior, ior)
    sin2_t = eta**2 * np.maximum(0.0, 1 - cos_i**2)
    tir = sin2_t > 1
    f0 = ((1 - ior) / (1 + ior)) ** 2
    cos_t = np.sqrt(np.maximum(0.0, 1 - sin2_t))
    cos_f = np.where(entering, cos_i, cos_t)
    return eta, cos_t, np.where(tir, 1.0, f0 + (1 - f0) * (1 - cos_f) ** 5)


def camera_rays(matrix_world, fov_y, width, height, shift=(0.0, 0.0), ortho_height=None):
    """Pinhole rays through pixel centres, rows top to bottom; the camera looks down its -z.
    ``shift``: where the image's centre lies on the image plane at distance 1 (a shifted lens,
    in the units of tan(fov_y / 2)): the view moves, its perspective stays. With
    ``ortho_height`` (the view's height in the camera's units) the rays are parallel instead,
    from the camera's plane (``fov_y`` is then unused and ``shift`` is in those units)."""
    m = np.asarray(matrix_world, float)
    if width < 1 or height < 1:
        raise ValueError(f"the image needs at least 1 x 1 pixels, got {width} x {height}")
    if ortho_height is not None:
        if not (np.isfinite(ortho_height) and ortho_height > 0):
            raise ValueError(f"the orthographic view's height must be > 0, got {ortho_height}")
        half_h = 0.5 * ortho_height
    elif not (0 < fov_y < np.pi):
        raise ValueError(f"the vertical field of view must be in (0, pi), got {fov_y}")
    else:
        half_h = np.tan(0.5 * fov_y)
    half_w = half_h * width / height
    x = ((np.arange(width) + 0.5) / width * 2 - 1) * half_w + shift[0]
    y = (1 - (np.arange(height) + 0.5) / height * 2) * half_h + shift[1]
    gx, gy = np.meshgrid(x, y)
    if ortho_height is not None:
        plane = np.stack([gx.ravel(), gy.ravel(), np.zeros(gx.size)], 1)
        axis = -m[:3, 2] / norms(m[:3, 2][None])[0]
        return plane @ m[:3, :3].T + m[:3, 3], np.broadcast_to(axis, plane.shape).copy()
    local = np.stack([gx.ravel(), gy.ravel(), -np.ones(gx.size)], 1)
    d = local @ m[:3, :3].T
    d /= norms(d)[:, None]
    return np.broadcast_to(m[:3, 3], d.shape).copy(), d


@dataclass(frozen=True)
class RenderSettings:
    """How ``render`` lights and bounces its rays. ``background`` a colour or a function of ray
    directions (n, 3) -> (n, 3); ``ambient`` the light every surface gets without a shadow ray;
    rays bounce ``max_depth`` times at most and stop where their weight falls below ``cutoff``;
    ``layered``: covered lower layers are seen through (the dissertation's layered tracing).
    ``clip``: (near, far) distances along each ray (numbers or one per ray) between which these
    rays see anything, as a camera's clipping planes cut what its rays see and nothing else:
    what they reflect, refract or are shadowed by is not clipped. Depth is from the origins.
    ``unseen``: a bool per object these rays pass through (hidden from the camera, as Cycles'
    Ray Visibility > Camera off); it still shows in reflections and casts its shadows.
    ``shadowless``: a bool per object that casts no shadow (Ray Visibility > Shadow off);
    ``unreflected`` and ``unrefracted``: a bool per object that reflected, or refracted, rays pass
    through (Ray Visibility > Glossy, Transmission off)."""

    background: object = (0.0, 0.0, 0.0)
    ambient: object = 0.0
    max_depth: int = 4
    cutoff: float = 0.01
    layered: bool = True
    clip: tuple | None = None
    unseen: object = None
    shadowless: object = None
    unreflected: object = None
    unrefracted: object = None


def render(scene: LayeredScene, surfaces, lights, origins, directions,
           settings: RenderSettings = RenderSettings()) -> Image:
    """Colour per ray. ``surfaces`` a ``Surfaces`` (Surfaces.build: materials per object, picked
    face by face, with UVs and shading normals), or one Material (or list of them) per object."""
    surfaces = surfaces if isinstance(surfaces, Surfaces) else Surfaces.build(scene, surfaces)
    if settings.max_depth < 0:
        raise ValueError(f"max_depth must be >= 0, got {settings.max_depth}")
    o, d = unit_rays(origins, directions)  # hit points, shading and Fresnel take them of length one
    near = far = None
    if settings.clip is not None:
        near, far = (np.broadcast_to(np.asarray(x, float), (len(o),)) for x in settings.clip)
        if not ((near >= 0) & (far > near)).all():
            raise ValueError("clip needs 0 <= near < far on every ray")
        # the rays start on the near plane, as Cycles starts them: no hit nearer counts
        o = o + d * near[:, None]
    first, colour, stats = _Whitted(scene, surfaces, lights, settings).trace(o, d, None if far is None else far - near)
    return Image(colour, first.t if near is None else first.t + near, first.obj, first.fixed, stats)


@dataclass
class _Rays:
    """A batch of rays in flight: where from, which way, which pixel each adds to, its weight, its
    depth, the absorption of the medium it travels in, and what it is (0 reflected, 1 refracted)."""

    o: np.ndarray
    d: np.ndarray
    pixel: np.ndarray
    weight: np.ndarray
    depth: np.ndarray
    sigma: np.ndarray
    kind: np.ndarray

    def take(self, keep) -> "_Rays":
        return _Rays(*(rows(x, keep) for x in (self.o, self.d, self.pixel, self.weight, self.depth, self.sigma)),
                     self.kind[keep])


class _Whitted:
    """One render's tracing: the material table, the sky, what shadow rays meet, and the bounces."""

    def __init__(self, scene, surfaces, lights, settings):
        self.scene, self.surfaces, self.lights, self.settings = scene, surfaces, lights, settings
        mats = surfaces.materials
        self.textured = [i for i, m in enumerate(mats) if m.texture is not None]
        background = settings.background
        self.sky = (background if callable(background)
                    else (lambda d: np.broadcast_to(np.asarray(background, float), d.shape)))
        self.stats = {"rays": 0, "shadow_rays": 0, "deepest": 0, "cut_by_importance": 0}
        self.albedo = np.array([m.colour for m in mats], float)
        self.absorb = np.array([m.absorption for m in mats], float)
        self.emission = np.array([m.emission for m in mats], float)
        self.glows = bool(self.emission.any())
        self.props = {k: np.array([getattr(m, k) for m in mats], float)
                      for k in ("transmission", "mirror", "ior", "specular", "shininess")}
        # what shadow rays meet, and each object's index there
        shadowless = settings.shadowless
        blockers = (scene, None) if shadowless is None or not np.any(shadowless) else scene.without(shadowless)
        self.shading = Shading(scene, lights, settings.ambient, settings.layered, self.stats, blockers)
        # the objects each kind of secondary ray passes through
        self.passes = [None if m is None or not np.any(m) else m for m in (settings.unreflected, settings.unrefracted)]

    def trace(self, o, d, reach):
        """(what the camera rays see first, colour per ray, stats); ``reach`` how far each camera
        ray sees (the far clip, from its start), or None."""
        n = len(o)
        rays = _Rays(o, d, np.arange(n), np.ones((n, 3)), np.zeros(n, int), np.zeros((n, 3)), np.zeros(n, np.int8))
        colour = np.zeros((n, 3))
        first = None
        absorbing = False  # whether any ray travels in an absorbing medium (camera rays: in air)
        leaving = np.zeros(n)  # secondary rays start on their surface and skip it
        once = True  # each pixel at most once in the batch (camera rays), so no np.add.at needed
        while len(rays.pixel):
            vis = self._visible(rays, leaving, once)
            self.stats["rays"] += len(rays.pixel)
            if first is None:
                if reach is not None:
                    beyond = np.flatnonzero(vis.t > reach)
                    vis.t[beyond], vis.obj[beyond], vis.face[beyond], vis.fixed[beyond] = np.inf, -1, -1, False
                first = vis
            hit = vis.obj >= 0
            if absorbing:  # exp over a frame's camera rays in air is 25 ms of multiplying by one
                # Beer-Lambert over the way to the hit (or to the background)
                travel = np.where(hit, vis.t, 0.0)
                rays.weight = rays.weight * np.exp(-rays.sigma * travel[:, None])
            if once:
                # camera rays: row i is pixel i and nothing is in it yet; most of a frame misses, and
                # the sky everywhere with the hits zeroed is a third of the time of scattering the misses
                colour = rays.weight * self.sky(rays.d)
                colour[hit] = 0.0
            else:
                miss = np.flatnonzero(~hit)  # integer takes: boolean ones of (n, 3) rows are slower
                _add(colour, rays.pixel[miss], rows(rays.weight, miss) * self.sky(rows(rays.d, miss)), False)
            if not hit.any():
                break
            keep = np.flatnonzero(hit)
            rays = rays.take(keep)
            rays = self._shade(rays, SurfaceHits(*(rows(x, keep) for x in (vis.obj, vis.face, vis.bary))),
                               rows(vis.t, keep), colour, once)
            if rays is None:
                break
            absorbing = bool(rays.sigma.any())
            rays.d = rays.d / np.linalg.norm(rays.d, axis=1, keepdims=True)
            leaving = np.full(len(rays.o), self.scene.eps)
            once = False  # a pixel's reflected and refracted rays travel together
        return first, colour, self.stats

    def _visible(self, rays, leaving, once):
        scene, layered, passes = self.scene, self.settings.layered, self.passes
        if once or (passes[0] is None and passes[1] is None):
            return scene.first_visible(rays.o, rays.d, layered=layered, min_dist=leaving, scaled=True,
                                       unseen=self.settings.unseen if once else None)
        return _first_visible_by_kind(scene, rays, leaving, layered, passes)

    def _shade(self, rays, hits: SurfaceHits, t, colour, once):
        """Add what the hits (``t`` along the rays) show to ``colour``; the reflected and refracted
        rays they send on (None when none goes on)."""
        obj, face, bary = hits.obj, hits.face, hits.bary
        scene, props, corners = self.scene, self.props, self.surfaces.corner_normals
        d = rays.d
        p = rays.o + d * t[:, None]
        nrm = shading_normal(scene, obj, face, bary, corners)
        entering = np.einsum("ij,ij->i", nrm, d) < 0
        nrm = np.where(entering[:, None], nrm, -nrm)  # faces the incoming ray
        mat = self.surfaces.face_material[scene.first_face[obj] + face]
        trans, mirror, ior = props["transmission"][mat], props["mirror"][mat], props["ior"][mat]
        local = (1 - trans) * (1 - mirror)
        start = shadow_origin(scene, hits, p, np.where(entering, 1.0, -1.0), corners) + nrm * scene.eps
        albedo_hit = self._albedo(mat, obj, face, bary)
        colour_local = direct_light(self.shading, LitPoints(p, start, nrm, d, obj, albedo_hit, props["specular"][mat],
                                                            props["shininess"][mat]))
        seen = rays.weight * local[:, None] * colour_local
        if self.glows:  # emission on top, whatever share of the light the surface reflects or lets through
            seen += rays.weight * self.emission[mat]
        _add(colour, rays.pixel, seen, once)
        cos_i = -np.einsum("ij,ij->i", nrm, d)
        eta, cos_t, fres = fresnel(cos_i, ior, entering)
        k_reflect = (1 - trans) * mirror + trans * fres
        k_refract = trans * (1 - fres)
        refl_d = d + 2 * cos_i[:, None] * nrm
        refr_d = eta[:, None] * d + (eta * cos_i - cos_t)[:, None] * nrm
        next_depth = rays.depth + 1
        self.stats["deepest"] = max(self.stats["deepest"], int(rays.depth.max()))
        batches = []
        for bounce, (k, direction, inside) in enumerate(((k_reflect, refl_d, rays.sigma), (k_refract, refr_d, None))):
            w = rays.weight * k[:, None]
            go = (k > 0) & (next_depth <= self.settings.max_depth)
            important = (w @ LUMA) >= self.settings.cutoff
            self.stats["cut_by_importance"] += int((go & ~important).sum())
            go &= important
            if not go.any():
                continue
            if inside is None:  # refracted rays enter (take the object's absorption) or leave (none)
                inside = np.where(entering[:, None], self.absorb[mat], 0.0)
            go = np.flatnonzero(go)
            batches.append((*(rows(x, go) for x in (p, direction, rays.pixel, w, next_depth, inside)),
                            np.full(len(go), bounce, np.int8)))
        if not batches:
            return None
        return _Rays(*(np.concatenate(parts) for parts in zip(*batches, strict=True)))

    def _albedo(self, mat, obj, face, bary):
        """The surface colour at each hit: its material's, or its texture's at the hit's UV."""
        albedo_hit = self.albedo[mat]
        uv_table, mats, first_face = self.surfaces.face_uvs, self.surfaces.materials, self.scene.first_face
        for i in self.textured:
            at = np.flatnonzero(mat == i)
            if len(at):
                uv = corner_blend(uv_table[first_face[obj[at]] + face[at]], bary[at])
                albedo_hit[at] = bilinear(mats[i].texture, uv)
        return albedo_hit


def _first_visible_by_kind(scene, rays, leaving, layered, passes):
    """first_visible of reflected (kind 0) and refracted (kind 1) rays, each kind passing through
    its own objects (``passes``: a mask per kind, or None)."""
    o, d, kind = rays.o, rays.d, rays.kind
    n = len(o)
    out = Visible(np.full(n, np.inf), np.full(n, -1), np.full(n, -1), np.zeros((n, 2)), np.zeros(n, bool), 0)
    for k, mask in enumerate(passes):
        sel = np.flatnonzero(kind == k)
        if not len(sel):
            continue
        part = scene.first_visible(rows(o, sel), rows(d, sel), layered=layered, min_dist=leaving[sel], scaled=True,
                                   unseen=mask)
        out.t[sel], out.obj[sel], out.face[sel], out.bary[sel], out.fixed[sel] = (part.t, part.obj, part.face,
                                                                              part.bary, part.fixed)
        out.skipped += part.skipped
    return out


def _add(colour, pixel, value, once):
    if once:
        colour[pixel] += value
    else:
        np.add.at(colour, pixel, value)


