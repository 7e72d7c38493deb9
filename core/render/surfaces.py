"""What the rays meet on a surface: materials (one per object, or picked face by face by its slot),
their textures at each hit's UV, and the shading normal there (smooth, or the corners' own
normals: flat faces, sharp edges, custom normals), with where a shadow ray leaves it."""

from dataclasses import dataclass, field

import numpy as np

from ..geometry.vectors import norms, rows


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
        """``materials`` one per object: a Material, or a list of them that ``face_slots`` (per
        object None or one slot per face; past the last slot, the last) picks from face by face;
        ``face_uvs`` per object None or (faces, 3, 2) UVs of each face's corners, for textured
        materials; ``corner_normals`` per object None (smooth: its vertex normals) or (faces, 3, 3)
        unit shading normals of each face's corners (flat faces, sharp edges and custom normals,
        as Blender gives them)."""
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


def corner_blend(corners, bary):
    """Per hit, the (3, k) corner values blended by the hit's barycentrics (u, v)."""
    u, v = bary[:, 0:1], bary[:, 1:2]
    return (1 - u - v) * corners[:, 0] + u * corners[:, 1] + v * corners[:, 2]


def bilinear(texture, uv):
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


def shading_normal(scene, obj, face, bary, corners=None):
    """The object's interpolated vertex normals (smooth shading), or its faces' corner normals
    blended; the face's own where they cancel out."""
    if corners is None:
        out = scene.interpolate(scene.stacked_shading_normals, obj, face, bary)
    else:
        out = corner_blend(corners[scene.first_face[obj] + face], bary)
    length = norms(out)
    bad = np.flatnonzero(length < 1e-12)
    if len(bad):
        glob = scene.first_face[obj[bad]] + face[bad]
        out[bad] = scene.scene.face_normals[glob]
        length[bad] = norms(out[bad])
    return out / np.maximum(length, 1e-300)[:, None]


@dataclass(frozen=True)
class SurfaceHits:
    """Where rays met a LayeredScene: the object, the face within it, (u, v) on the face."""

    obj: np.ndarray
    face: np.ndarray
    bary: np.ndarray


def shadow_origin(scene, hits: SurfaceHits, p, side, corner_normals=None):
    """Where shadow rays should leave smooth-shaded hits (at ``p``): each point moved out to the
    smooth surface its vertex normals (or its face's ``corner_normals``) describe (Hanika, "Hacking
    the shadow terminator", Ray Tracing Gems II ch. 4), so a coarse or folded triangle does not
    shadow itself where its shading says it is lit. ``side``: +1 on the side the normals point
    to, -1 on the other."""
    bary = hits.bary
    glob = scene.first_face[hits.obj] + hits.face
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
