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
