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

LUMA = np.array([0.299, 0.587, 0.114])  # NTSC luminance weights


@dataclass(frozen=True)
class Material:
    colour: tuple = (0.8, 0.8, 0.8)
    specular: float = 0.0  # Blinn-Phong weight
    shininess: float = 32.0
    mirror: float = 0.0  # share reflected as a mirror (opaque part)
    transmission: float = 0.0  # share refracted
    ior: float = 1.5
    absorption: tuple = (0.0, 0.0, 0.0)  # Beer-Lambert coefficient per unit length, inside
    emission: tuple = (0.0, 0.0, 0.0)  # radiance the surface sends itself, on top of what it reflects
    # (h, w, 3) linear RGB in place of ``colour``, row 0 at v = 0, read at the faces' UVs
    # (``render``'s face_uvs) with bilinear filtering, repeating past 0..1 (Cycles' defaults)
    texture: np.ndarray | None = field(default=None, compare=False)


@dataclass(frozen=True)
class Light:
    """"SUN" (vector: the direction the light travels; colour: irradiance), "POINT" (vector:
    position; colour: intensity, falling as 1/r^2), "SPOT" (a point light shining along
    ``axis`` into a cone of full angle ``spot_size``, its edge softened as Blender's: a smoothstep
    over the outer ``spot_blend`` share of the cone's cosine range; the intensity inside is a
    point light's) or "AREA" (vector: centre; edges: the two half-edge vectors of a rectangle, or
    of the box around an ellipse with ``disk``; it emits on the side of u x v as a Lambertian
    surface; colour: intensity along that normal, P/pi for P watts; sampled on a ``samples`` x
    ``samples`` grid, so shadows are soft)."""

    kind: str
    vector: tuple
    colour: tuple = (1.0, 1.0, 1.0)
    edges: tuple = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    disk: bool = False
    samples: int = 4
    axis: tuple = (0.0, 0.0, -1.0)
    spot_size: float = np.pi / 4
    spot_blend: float = 0.15
    shadow: bool = True  # False: lights what faces it, through anything


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


@dataclass
class Surfaces:
    """What shading needs of a scene's faces, put together once (a frame renders in bands):
    every material once per object slot and the row of it each face takes, each face's
    corner UVs (only with a textured material) and corner normals (None: vertex normals)."""

    materials: list
    face_material: np.ndarray
    face_uvs: np.ndarray | None
    corner_normals: np.ndarray | None

    @classmethod
    def build(cls, scene, materials, face_slots=None, face_uvs=None, corner_normals=None):
        """See ``render``."""
        if len(materials) != len(scene.layers):
            raise ValueError(f"{len(materials)} materials for {len(scene.layers)} objects")
        mats, face_material = _material_table(scene, materials, face_slots)
        textured = any(m.texture is not None for m in mats)
        uvs = _face_table(scene, face_uvs, "face_uvs", 2, lambda a, b: np.zeros((b - a, 3, 2))) if textured else None
        normals = None
        if corner_normals is not None and any(c is not None for c in corner_normals):
            normals = _face_table(scene, corner_normals, "corner_normals", 3,
                                  lambda a, b: scene.stacked_shading_normals[scene.scene.faces[a:b]])
        return cls(mats, face_material, uvs, normals)


def render(scene: LayeredScene, materials, lights, origins, directions, background=(0.0, 0.0, 0.0),
           ambient=0.0, max_depth=4, cutoff=0.01, layered=True, face_slots=None, face_uvs=None,
           corner_normals=None, clip=None, unseen=None, shadowless=None, unreflected=None,
           unrefracted=None) -> Image:
    """Colour per ray. ``materials`` one per object: a Material, or a list of them that
    ``face_slots`` (per object None or one slot per face; past the last slot, the last) picks
    from face by face; ``face_uvs`` per object None or (faces, 3, 2) UVs of each face's corners,
    for textured materials; ``corner_normals`` per object None (smooth: its vertex normals) or
    (faces, 3, 3) unit shading normals of each face's corners (flat faces, sharp edges and
    custom normals, as Blender gives them); or ``materials`` a ``Surfaces`` built from all of
    these once. ``background`` a colour or a function of ray directions (n, 3) -> (n, 3).
    ``clip``: (near, far) distances along each ray (numbers or one per ray) between which these
    rays see anything, as a camera's clipping planes cut what its rays see and nothing else:
    what they reflect, refract or are shadowed by is not clipped. Depth is from the origins.
    ``unseen``: a bool per object these rays pass through (hidden from the camera, as Cycles'
    Ray Visibility > Camera off); it still shows in reflections and casts its shadows.
    ``shadowless``: a bool per object that casts no shadow (Ray Visibility > Shadow off);
    ``unreflected`` and ``unrefracted``: a bool per object that reflected, or refracted, rays pass
    through (Ray Visibility > Glossy, Transmission off)."""
    surfaces = (materials if isinstance(materials, Surfaces)
                else Surfaces.build(scene, materials, face_slots, face_uvs, corner_normals))
    mats, face_material = surfaces.materials, surfaces.face_material
    uv_table, corners = surfaces.face_uvs, surfaces.corner_normals
    textured = [i for i, m in enumerate(mats) if m.texture is not None]
    if max_depth < 0:
        raise ValueError(f"max_depth must be >= 0, got {max_depth}")
    sky = background if callable(background) else (lambda d: np.broadcast_to(np.asarray(background, float), d.shape))
    o, d = unit_rays(origins, directions)  # hit points, shading and Fresnel take them of length one
    n = len(o)
    near = far = None
    if clip is not None:
        near, far = (np.broadcast_to(np.asarray(x, float), (n,)) for x in clip)
        if not ((near >= 0) & (far > near)).all():
            raise ValueError("clip needs 0 <= near < far on every ray")
        # the rays start on the near plane, as Cycles starts them: no hit nearer counts
        o = o + d * near[:, None]
    colour = np.zeros((n, 3))
    pixel = np.arange(n)
    weight = np.ones((n, 3))
    depth_of = np.zeros(n, int)
    sigma = np.zeros((n, 3))  # absorption of the medium each ray travels in
    absorbing = False  # whether any ray travels in an absorbing medium (camera rays: in air)
    first, stats = None, {"rays": 0, "shadow_rays": 0, "deepest": 0, "cut_by_importance": 0}
    albedo = np.array([m.colour for m in mats], float)
    absorb = np.array([m.absorption for m in mats], float)
    emission = np.array([m.emission for m in mats], float)
    glows = bool(emission.any())
    props = {k: np.array([getattr(m, k) for m in mats], float)
             for k in ("transmission", "mirror", "ior", "specular", "shininess")}
    # what shadow rays meet, and each object's index there
    blockers = (scene, None) if shadowless is None or not np.any(shadowless) else scene.without(shadowless)
    leaving = np.zeros(n)  # secondary rays start on their surface and skip it
    once = True  # each pixel at most once in the batch (camera rays), so no np.add.at needed
    # what each secondary ray is (0 reflected, 1 refracted) and the objects each kind passes through
    kind = np.zeros(n, np.int8)
    passes = [None if m is None or not np.any(m) else m for m in (unreflected, unrefracted)]
    while len(pixel):
        if once or (passes[0] is None and passes[1] is None):
            vis = scene.first_visible(o, d, layered=layered, min_dist=leaving, scaled=True,
                                      unseen=unseen if once else None)
        else:
            vis = _first_visible_by_kind(scene, o, d, layered, leaving, kind, passes)
        stats["rays"] += len(pixel)
        if first is None:
            if far is not None:
                beyond = np.flatnonzero(vis.t > far - near)
                vis.t[beyond], vis.obj[beyond], vis.face[beyond], vis.fixed[beyond] = np.inf, -1, -1, False
            first = vis
        hit = vis.obj >= 0
        if absorbing:  # exp over a frame's camera rays in air is 25 ms of multiplying by one
            # Beer-Lambert over the way to the hit (or to the background)
            travel = np.where(hit, vis.t, 0.0)
            weight = weight * np.exp(-sigma * travel[:, None])
        if once:
            # camera rays: row i is pixel i and nothing is in it yet; most of a frame misses, and
            # the sky everywhere with the hits zeroed is a third of the time of scattering the misses
            colour = weight * sky(d)
            colour[hit] = 0.0
        else:
            miss = np.flatnonzero(~hit)  # integer takes: boolean ones of (n, 3) rows are slower
            _add(colour, pixel[miss], rows(weight, miss) * sky(rows(d, miss)), False)
        if not hit.any():
            break
        keep = np.flatnonzero(hit)
        o, d, pixel, weight, depth_of, sigma = (rows(x, keep) for x in (o, d, pixel, weight, depth_of, sigma))
        kind = kind[keep]
        obj, face, bary, t = (rows(x, keep) for x in (vis.obj, vis.face, vis.bary, vis.t))
        p = o + d * t[:, None]
        nrm = _shading_normal(scene, obj, face, bary, corners)
        entering = np.einsum("ij,ij->i", nrm, d) < 0
        nrm = np.where(entering[:, None], nrm, -nrm)  # faces the incoming ray
        mat = face_material[scene.first_face[obj] + face]
        trans, mirror, ior = props["transmission"][mat], props["mirror"][mat], props["ior"][mat]
        local = (1 - trans) * (1 - mirror)
        start = _shadow_origin(scene, obj, face, bary, p, np.where(entering, 1.0, -1.0), corners) + nrm * scene.eps
        albedo_hit = albedo[mat]
        for i in textured:
            at = np.flatnonzero(mat == i)
            if len(at):
                uv = _corner_blend(uv_table[scene.first_face[obj[at]] + face[at]], bary[at])
                albedo_hit[at] = _bilinear(mats[i].texture, uv)
        colour_local = _direct(scene, lights, p, start, nrm, d, albedo_hit, props["specular"][mat],
                               props["shininess"][mat], ambient, stats, layered, obj, blockers)
        seen = weight * local[:, None] * colour_local
        if glows:  # emission on top, whatever share of the light the surface reflects or lets through
            seen += weight * emission[mat]
        _add(colour, pixel, seen, once)
        cos_i = -np.einsum("ij,ij->i", nrm, d)
        eta, cos_t, fres = fresnel(cos_i, ior, entering)
        k_reflect = (1 - trans) * mirror + trans * fres
        k_refract = trans * (1 - fres)
        refl_d = d + 2 * cos_i[:, None] * nrm
        refr_d = eta[:, None] * d + (eta * cos_i - cos_t)[:, None] * nrm
        next_depth = depth_of + 1
        stats["deepest"] = max(stats["deepest"], int(depth_of.max()))
        batches = []
        for bounce, (k, direction, inside) in enumerate(((k_reflect, refl_d, sigma), (k_refract, refr_d, None))):
            w = weight * k[:, None]
            go = (k > 0) & (next_depth <= max_depth)
            important = (w @ LUMA) >= cutoff
            stats["cut_by_importance"] += int((go & ~important).sum())
            go &= important
            if not go.any():
                continue
            if inside is None:  # refracted rays enter (take the object's absorption) or leave (none)
                inside = np.where(entering[:, None], absorb[mat], 0.0)
            go = np.flatnonzero(go)
            batches.append((*(rows(x, go) for x in (p, direction, pixel, w, next_depth, inside)),
                            np.full(len(go), bounce, np.int8)))
        if not batches:
            break
        o, d, pixel, weight, depth_of, sigma, kind = (np.concatenate(parts) for parts in zip(*batches, strict=True))
        absorbing = bool(sigma.any())
        d = d / np.linalg.norm(d, axis=1, keepdims=True)
        leaving = np.full(len(o), scene.eps)
        once = False  # a pixel's reflected and refracted rays travel together
    return Image(colour, first.t if near is None else first.t + near, first.obj, first.fixed, stats)


def _first_visible_by_kind(scene, o, d, layered, leaving, kind, passes):
    """first_visible of reflected (kind 0) and refracted (kind 1) rays, each kind passing through
    its own objects (``passes``: a mask per kind, or None)."""
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


def _material_table(scene, materials, face_slots):
    """(every material once per object slot, the row of it each face of the combined scene takes)."""
    if face_slots is not None and len(face_slots) != len(materials):
        raise ValueError(f"face_slots needs one entry per object ({len(materials)}), got {len(face_slots)}")
    table, rows = [], []
    for i, m in enumerate(materials):
        group = [m] if isinstance(m, Material) else list(m)
        if not group or not all(isinstance(x, Material) for x in group):
            raise ValueError(f"materials[{i}] must be a Material or a non-empty list of them")
        for x in group:
            t = x.texture
            if t is not None and (np.ndim(t) != 3 or np.shape(t)[2] != 3 or 0 in np.shape(t)
                                  or not np.isfinite(t).all()):
                raise ValueError(f"a texture of materials[{i}] must be finite (h, w, 3) RGB, got shape {np.shape(t)}")
        count = int(scene.first_face[i + 1] - scene.first_face[i])
        slots = None if face_slots is None else face_slots[i]
        if slots is None:
            slot = np.zeros(count, np.int64)
        else:
            slot = np.asarray(slots, np.int64)
            if slot.shape != (count,):
                raise ValueError(f"face_slots[{i}] must be one slot per face ({count}), got shape {slot.shape}")
            slot = np.clip(slot, 0, len(group) - 1)
        rows.append(len(table) + slot)
        table += group
    return table, (np.concatenate(rows) if rows else np.zeros(0, np.int64))


def _face_table(scene, per_object, name, width, default):
    """(faces of the combined scene, 3, width) corner values from one (faces, 3, width) array or
    None per object; ``default(first, stop)`` fills an object's rows where it has None."""
    if per_object is None:
        per_object = [None] * len(scene.layers)
    if len(per_object) != len(scene.layers):
        raise ValueError(f"{name} needs one entry per object ({len(scene.layers)}), got {len(per_object)}")
    parts = []
    for i, given in enumerate(per_object):
        a, b = int(scene.first_face[i]), int(scene.first_face[i + 1])
        if given is None:
            parts.append(default(a, b))
            continue
        given = np.asarray(given, float)
        if given.shape != (b - a, 3, width) or not np.isfinite(given).all():
            raise ValueError(f"{name}[{i}] must be finite with shape ({b - a}, 3, {width}), got {given.shape}")
        parts.append(given)
    return np.concatenate(parts) if parts else np.zeros((0, 3, width))


def _corner_blend(corners, bary):
    """Per hit, the (3, k) corner values blended by the hit's barycentrics (u, v)."""
    u, v = bary[:, 0:1], bary[:, 1:2]
    return (1 - u - v) * corners[:, 0] + u * corners[:, 1] + v * corners[:, 2]


def _bilinear(texture, uv):
    """Texture (h, w, c) at UVs (n, 2): texel centres at (i + 0.5) / w, bilinear between them,
    repeating past the edges."""
    h, w = texture.shape[:2]
    x, y = uv[:, 0] * w - 0.5, uv[:, 1] * h - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    x0, y0 = x0.astype(np.int64) % w, y0.astype(np.int64) % h
    x1, y1 = (x0 + 1) % w, (y0 + 1) % h
    top = texture[y0, x0] * (1 - fx) + texture[y0, x1] * fx
    bottom = texture[y1, x0] * (1 - fx) + texture[y1, x1] * fx
    return top * (1 - fy) + bottom * fy


def _add(colour, pixel, value, once):
    if once:
        colour[pixel] += value
    else:
        np.add.at(colour, pixel, value)


def _shading_normal(scene, obj, face, bary, corners=None):
    """The object's interpolated vertex normals (smooth shading), or its faces' corner normals
    blended; the face's own where they cancel out."""
    if corners is None:
        out = scene.interpolate(scene.stacked_shading_normals, obj, face, bary)
    else:
        out = _corner_blend(corners[scene.first_face[obj] + face], bary)
    length = norms(out)
    bad = np.flatnonzero(length < 1e-12)
    if len(bad):
        glob = scene.first_face[obj[bad]] + face[bad]
        out[bad] = scene.scene.face_normals[glob]
        length[bad] = norms(out[bad])
    return out / np.maximum(length, 1e-300)[:, None]


def _shadow_origin(scene, obj, face, bary, p, side, corner_normals=None):
    """Where shadow rays should leave a smooth-shaded hit: the point moved out to the smooth
    surface its vertex normals (or its face's ``corner_normals``) describe (Hanika, "Hacking
    the shadow terminator", Ray Tracing Gems II ch. 4), so a coarse or folded triangle does not
    shadow itself where its shading says it is lit. ``side``: +1 on the side the normals point
    to, -1 on the other."""
    glob = scene.first_face[obj] + face
    corners = rows(scene.scene.faces, glob)
    weights = (1 - bary[:, 0] - bary[:, 1], bary[:, 0], bary[:, 1])
    # p lifted out of each corner's tangent plane (normal side * n) where it lies below it,
    # blended by the weights (they sum to one); corner by corner on (n, 3) rows, as (n, 3, 3)
    # temporaries of a frame's hits do not fit in cache
    moved = np.zeros_like(p)
    for k, w in enumerate(weights):
        n = rows(scene.stacked_shading_normals, corners[:, k]) if corner_normals is None else corner_normals[glob, k]
        below = np.minimum(0.0, side * np.einsum("ij,ij->i", p - rows(scene.scene.vertices, corners[:, k]), n))
        moved += (w * below)[:, None] * n
    return p - side[:, None] * moved


def _direct(scene, lights, p, start, nrm, d, albedo, spec, shine, ambient, stats, layered, obj, blockers=None):
    """Blinn-Phong from each light that the point sees (shadow rays), plus ambient. In layered
    tracing a covered lower layer casts no shadow: a surface that is not shown must not darken
    the one shown over it. Shadow rays leave from ``start``; ``blockers``: (the scene they meet,
    each object's index in it) when some objects cast no shadow."""
    blocker, index = blockers if blockers is not None else (scene, None)
    out = ambient * albedo
    for kind, vec, colour, reach, casts in _emitters(lights):
        if kind == "SUN":
            to_l = np.broadcast_to(-vec / np.linalg.norm(vec), p.shape)
            dist = np.full(len(p), np.inf)
            power = np.broadcast_to(colour, p.shape)
        else:
            to_l = vec - p
            dist = np.linalg.norm(to_l, axis=1)
            to_l = to_l / np.maximum(dist, 1e-300)[:, None]
            power = colour / np.maximum(dist, 1e-300)[:, None] ** 2
        lit = np.einsum("ij,ij->i", nrm, to_l) > 0
        if reach is not None:  # how much of it leaves towards each point (a spot's cone, a patch's side)
            share = reach(-to_l)
            power = power * share[:, None]
            lit &= share > 0  # no shadow ray where no light comes
        if not lit.any():
            continue
        idx = np.flatnonzero(lit)
        if casts:
            leaving = obj[idx] if index is None else index[obj[idx]]
            shadow = blocker.blocked(start[idx], to_l[idx], dist[idx] - 2 * scene.eps, layered=layered,
                                     leaving=leaving)
            stats["shadow_rays"] += len(idx)
            idx = idx[~shadow]
        n_i, l_i = rows(nrm, idx), rows(to_l, idx)
        cos = np.einsum("ij,ij->i", n_i, l_i)
        shade = rows(albedo, idx) * cos[:, None]
        if spec[idx].any():  # no highlight to add on purely diffuse surfaces
            half = l_i - rows(d, idx)
            half /= np.maximum(norms(half), 1e-300)[:, None]
            blinn = np.maximum(0.0, np.einsum("ij,ij->i", n_i, half)) ** shine[idx]
            shade += (spec[idx] * blinn)[:, None]
        out[idx] += rows(power, idx) * shade
    return out


def _emitters(lights):
    """(kind, vector, colour, reach, casts shadows) per sun, point, spot, or sample of an area
    light; ``reach``: None, or the share of the intensity sent along each (n, 3) unit direction
    from the light."""
    for light in lights:
        vec, colour, casts = np.asarray(light.vector, float), np.asarray(light.colour, float), bool(light.shadow)
        if light.kind in ("SUN", "POINT"):
            yield light.kind, vec, colour, None, casts
        elif light.kind == "SPOT":
            yield "POINT", vec, colour, _spot_cone(light), casts
        elif light.kind == "AREA":
            u, v = (np.asarray(e, float) for e in light.edges)
            facing = np.cross(u, v)
            if np.linalg.norm(facing) == 0 or light.samples < 1:
                raise ValueError("an area light needs two independent edges and samples >= 1")
            facing = facing / np.linalg.norm(facing)
            s = (np.arange(light.samples) + 0.5) / light.samples * 2 - 1
            a, b = (g.ravel() for g in np.meshgrid(s, s))
            if light.disk:
                keep = a**2 + b**2 <= 1
                a, b = a[keep], b[keep]

            def lambert(out, facing=facing):  # nothing behind the patch
                return np.maximum(0.0, out @ facing)

            for x, y in zip(a, b, strict=True):
                yield "POINT", vec + x * u + y * v, colour / len(a), lambert, casts
        else:
            raise ValueError(f"light kind must be SUN, POINT, SPOT or AREA, got {light.kind!r}")


def _spot_cone(light):
    """A spot's share of its intensity along each unit direction: 1 inside the cone, a smoothstep
    over the outer ``spot_blend`` of its cosine range (Cycles' spot attenuation), 0 outside."""
    axis = np.asarray(light.axis, float)
    size, blend = float(light.spot_size), float(light.spot_blend)
    if not np.linalg.norm(axis) > 0 or not 0 < size <= np.pi or not 0 <= blend <= 1:
        raise ValueError(f"a spot light needs an axis, spot_size in (0, pi] and spot_blend in [0, 1]; got "
                         f"axis {tuple(axis)}, spot_size {size}, spot_blend {blend}")
    axis = axis / np.linalg.norm(axis)
    cos_half = float(np.cos(size / 2))
    soft = (1.0 - cos_half) * blend

    def share(out):
        c = out @ axis
        if soft <= 0:
            return (c > cos_half).astype(float)
        x = np.clip((c - cos_half) / soft, 0.0, 1.0)
        return x * x * (3.0 - 2.0 * x)

    return share
