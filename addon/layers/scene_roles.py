"""Which objects of a scene take part in layering, in layer order."""

import re

# Integer vertex attributes holding a body's parts in each segmentation scheme (core.segmentation).
PART_ATTRIBUTE = {"S5": "deformrt_part_s5", "S13": "deformrt_part_s13"}



# Which garments are worn over which, by the words in their names (after MakeHuman's
# z_depth table): underwear < shirts and trousers < sweaters < jackets < coats.
_KIND_RANK = (
    (0, ("underwear", "bra", "panties", "briefs", "boxers", "boxer", "sock", "socks", "tights", "stocking",
         "stockings", "undershirt", "lingerie", "bodysuit", "leotard")),
    (2, ("sweater", "pullover", "jumper", "hoodie", "cardigan", "vest", "waistcoat", "fleece", "sweatshirt")),
    (3, ("jacket", "blazer", "anorak", "gilet")),
    (4, ("coat", "overcoat", "parka", "cloak", "cape", "raincoat", "poncho", "trenchcoat")),
)


def kind_rank(name: str) -> float:
    """How far out a garment of this name is usually worn (1 for shirts, trousers, dresses
    and anything unknown); an "over" prefix (overshirt, overdress) puts it half a step out."""
    words = [w for w in re.split(r"[^a-z]+", name.lower()) if w]
    rank = 1.0
    for value, keys in _KIND_RANK:
        if any(w in keys or (w.startswith("over") and w[4:] in keys) for w in words):
            rank = float(value)
            break
    if any(w.startswith("over") and len(w) > 4 for w in words):
        rank += 0.5
    return rank


# MPFB2 (MakeHuman for Blender) keeps what each of its objects is in a string property of the
# object (its GeneralObjectProperties, prefix MPFB_GEN_; older files: MhObjectType) and, for
# clothes made or loaded with MakeClothes, the MHCLO z_depth (MakeClothesObjectProperties, MC_).
# Registered or not (MPFB2 need not be installed), their values live in the object's ID properties.
MPFB_TYPE_KEYS = ("MPFB_GEN_object_type", "MhObjectType")
MPFB_Z_DEPTH_KEYS = ("MC_z_depth", "MPFB_GEN_z_depth")


BODY_TYPES = ("Basemesh", "Proxymeshes")  # MPFB2's object types a character's body can be


def mpfb_type(obj) -> str:
    """MPFB2's object type ("Basemesh", "Proxymeshes", "Clothes", "Eyes", ...) or ""."""
    for key in MPFB_TYPE_KEYS:
        value = obj.get(key)
        if isinstance(value, str) and value:
            return value
    return ""


def _z_depth(obj):
    for key in MPFB_Z_DEPTH_KEYS:
        value = obj.get(key)
        if isinstance(value, (int, float)) and not isinstance(value, bool):
            return float(value)
    return None


def _character_root(obj):
    while obj.parent is not None:
        obj = obj.parent
    return obj


def mpfb_character(scene, near=None):
    """(body, clothes inner to outer, "z_depth" or "kind") of the MPFB2 character that holds
    ``near`` (else the only one in the scene), or None. The body is the proxy mesh that replaces
    the base mesh when there is one that renders; clothes go in MakeHuman's z_depth order when
    every piece has one, else by kind of name (underwear < shirts, trousers < sweaters < jackets
    < coats). Eyes, eyebrows, hair and teeth are not garments."""
    meshes = [o for o in scene.objects if o.type == "MESH" and mpfb_type(o) and not _baked(o)]
    roots = {_character_root(o) for o in meshes if mpfb_type(o) in BODY_TYPES}
    if near is not None and _character_root(near) in roots:
        roots = {_character_root(near)}
    if len(roots) != 1:
        return None
    root = roots.pop()
    own = [o for o in meshes if _character_root(o) is root]
    kind = {o: mpfb_type(o) for o in own}
    proxies = [o for o in own if kind[o] == "Proxymeshes" and not o.hide_render]
    bases = [o for o in own if kind[o] == "Basemesh"]
    # a character whose base mesh was deleted (MPFB2 allows it once a proxy is fitted) is its proxy
    body = (proxies or bases or [o for o in own if kind[o] == "Proxymeshes"])[0]
    clothes = [o for o in own if kind[o] == "Clothes"]
    depths = [_z_depth(o) for o in clothes]
    if all(d is not None for d in depths):
        order = dict(zip(clothes, depths, strict=True))
        return body, sorted(clothes, key=lambda o: (order[o], kind_rank(o.name), o.name)), "z_depth"
    return body, sorted(clothes, key=lambda o: (kind_rank(o.name), o.name)), "kind"


# Baked copies keep their role and layer for the tools they are exported to, but are not
# inputs of the scene's own layering.
BAKED_COLLECTION = "DeformRT Baked"


def _baked(obj) -> bool:
    return any(c.name == BAKED_COLLECTION for c in obj.users_collection)


def is_tagged_mesh(obj) -> bool:
    return obj.type == "MESH" and obj.deformrt.role in {"BODY", "GARMENT"}


def tagged(scene, role):
    return [o for o in scene.objects if o.deformrt.role == role and not _baked(o)]


def bodies(scene):
    return [o for o in tagged(scene, "BODY") if o.type == "MESH"]


def garments(scene):
    """Garment objects, inner to outer (ties broken by name so the order is stable)."""
    found = [o for o in tagged(scene, "GARMENT") if o.type == "MESH"]
    return sorted(found, key=lambda o: (o.deformrt.layer, o.name))


def top_layer(scene) -> int:
    return max((o.deformrt.layer for o in garments(scene)), default=0)
