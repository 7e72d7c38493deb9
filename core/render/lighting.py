"""Lights and the direct light at a point (thesis eq. 2.7-2.8): Blinn-Phong from each light the
point sees through its shadow rays, plus ambient; suns, points, spots (with their cones) and
area lights as Blender has them."""

from dataclasses import dataclass

import numpy as np

from ..geometry.vectors import norms, rows


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
class Shading:
    """What lights a render's points: its LayeredScene and lights, the ambient light, whether it
    traces layered, its stats (``shadow_rays`` counted), and ``blockers``: (the scene shadow rays
    meet, each object's index in it) when some objects cast no shadow, else None."""

    scene: object
    lights: list
    ambient: object
    layered: bool
    stats: dict
    blockers: tuple | None = None


@dataclass
class LitPoints:
    """Points to light: where they are (``p``), where their shadow rays leave from (``start``),
    their normals facing the viewer, the rays that met them (``d``), the object each is on, and
    their material's albedo, specular weight and shininess."""

    p: np.ndarray
    start: np.ndarray
    nrm: np.ndarray
    d: np.ndarray
    obj: np.ndarray
    albedo: np.ndarray
    spec: np.ndarray
    shine: np.ndarray


def direct_light(shading: Shading, at: LitPoints):
    """Blinn-Phong from each light that the point sees (shadow rays), plus ambient. In layered
    tracing a covered lower layer casts no shadow: a surface that is not shown must not darken
    the one shown over it."""
    scene, p, nrm, albedo = shading.scene, at.p, at.nrm, at.albedo
    blocker, index = shading.blockers if shading.blockers is not None else (scene, None)
    out = shading.ambient * albedo
    for kind, vec, colour, reach, casts in _emitters(shading.lights):
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
            leaving = at.obj[idx] if index is None else index[at.obj[idx]]
            shadow = blocker.blocked(at.start[idx], to_l[idx], dist[idx] - 2 * scene.eps, layered=shading.layered,
                                     leaving=leaving)
            shading.stats["shadow_rays"] += len(idx)
            idx = idx[~shadow]
        n_i, l_i = rows(nrm, idx), rows(to_l, idx)
        cos = np.einsum("ij,ij->i", n_i, l_i)
        shade = rows(albedo, idx) * cos[:, None]
        if at.spec[idx].any():  # no highlight to add on purely diffuse surfaces
            half = l_i - rows(at.d, idx)
            half /= np.maximum(norms(half), 1e-300)[:, None]
            blinn = np.maximum(0.0, np.einsum("ij,ij->i", n_i, half)) ** at.shine[idx]
            shade += (at.spec[idx] * blinn)[:, None]
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
