"""Materials and textures as DeformRT Layered shades them: the Principled BSDF's base colour (or
an Image Texture feeding it straight), metallic as mirror, transmission and IOR, roughness as
Blinn-Phong shininess, emission; slot by slot."""

import numpy as np

from ...core.render.surfaces import Material
from ..io import blender_versions


def materials(obj, depsgraph, known):
    """The Materials of the object's slots as it is evaluated (geometry nodes may set some), in
    slot order. A slot without a material, or an object without slots, takes the object's
    colour where one was set (Object > Viewport Display), else Cycles' default grey of 0.8.
    ``known``: Blender material -> Material, for this frame (each texture read once, however
    many objects or instances wear it)."""
    ev = obj.evaluated_get(depsgraph)
    own = tuple(ev.color[:3])
    fallback = Material(colour=own if own != (1.0, 1.0, 1.0) else (0.8, 0.8, 0.8))
    out = []
    for slot in ev.material_slots:
        mat = slot.material
        key = None if mat is None else mat.as_pointer()
        if key not in known:
            known[key] = material(mat)
        out.append(known[key] or fallback)
    return out or [fallback]


def material(mat):
    """The Material of a Blender material; None for no material."""
    if mat is None:
        return None
    bsdf = mat.node_tree.nodes.get("Principled BSDF") if blender_versions.uses_nodes(mat) else None
    if bsdf is None:
        return Material(colour=tuple(mat.diffuse_color[:3]))
    value = lambda name: bsdf.inputs[name].default_value  # noqa: E731
    rough = float(value("Roughness"))
    return Material(colour=tuple(value("Base Color")[:3]), texture=base_texture(bsdf),
                    specular=0.5 * float(value("Specular IOR Level")),
                    shininess=2.0 / max(rough**4, 1e-4), mirror=float(value("Metallic")),
                    transmission=float(value("Transmission Weight")), ior=float(value("IOR")),
                    emission=tuple(float(value("Emission Strength")) * np.array(value("Emission Color")[:3])))


def base_texture(bsdf):
    """The (h, w, 3) linear RGB of an Image Texture node whose colour feeds the Base Color straight,
    read at the UV map that renders (its Vector unlinked, or from a UV Map node left on the
    default map or a Texture Coordinate node's UV); None for anything else, which leaves the
    socket's own colour."""
    links = bsdf.inputs["Base Color"].links
    node = links[0].from_node if links else None
    if node is None or node.type != "TEX_IMAGE" or node.image is None or links[0].from_socket.name != "Color":
        return None
    vector = node.inputs["Vector"].links
    source = vector[0].from_node if vector else None
    if source is not None and not ((source.type == "UVMAP" and not source.uv_map)
                                   or (source.type == "TEX_COORD" and vector[0].from_socket.name == "UV")):
        return None  # another map, or coordinates of another kind
    image = node.image
    w, h = image.size
    channels = image.channels
    if not w or not h or channels < 3:
        return None
    pixels = np.empty(w * h * channels, dtype=np.float32)
    image.pixels.foreach_get(pixels)  # rows bottom up, as UV v runs
    rgb = np.ascontiguousarray(pixels.reshape(h, w, channels)[..., :3])  # float32: a 4k image is 190 MB
    del pixels
    if image.colorspace_settings.name == "sRGB":
        low = rgb <= 0.04045
        rgb = np.where(low, rgb / np.float32(12.92), ((rgb + np.float32(0.055)) / np.float32(1.055)) ** np.float32(2.4))
    return rgb
