"""Which objects of a scene take part in layering, in layer order."""

# Integer vertex attributes holding a body's parts in each segmentation scheme (core.segmentation).
PART_ATTRIBUTE = {"S5": "deformrt_part_s5", "S13": "deformrt_part_s13"}


def is_tagged_mesh(obj) -> bool:
    return obj.type == "MESH" and obj.deformrt.role in {"BODY", "GARMENT"}


def bodies(scene):
    return [o for o in scene.objects if o.type == "MESH" and o.deformrt.role == "BODY"]


def garments(scene):
    """Garment objects, inner to outer (ties broken by name so the order is stable)."""
    found = [o for o in scene.objects if o.type == "MESH" and o.deformrt.role == "GARMENT"]
    return sorted(found, key=lambda o: (o.deformrt.layer, o.name))


def top_layer(scene) -> int:
    return max((o.deformrt.layer for o in garments(scene)), default=0)
