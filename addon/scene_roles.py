"""Which objects of a scene take part in layering, in layer order."""

# Integer vertex attributes holding a body's parts in each segmentation scheme (core.segmentation).
PART_ATTRIBUTE = {"S5": "deformrt_part_s5", "S13": "deformrt_part_s13"}


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
