"""Tubes: a capped cylinder 'body' with two noisy open sleeves that cut through each other.

The smallest scene with the layering problem: each sleeve alone clears the body,
together they interpenetrate. Used by the demo until the mannequin scenes land.
"""


from ..addon.io import mesh_io
from . import shapes, studio

LAYERS = (
    # name, radius_m, colour
    ("Shirt", 0.165, (0.80, 0.15, 0.12, 1.0)),
    ("Jacket", 0.170, (0.10, 0.35, 0.75, 1.0)),
)
NOISE = 0.012  # m


def build(seed: int = 0, resolution: int = 96):
    """Replace the current scene's contents with the tubes scene; returns (body, garments)."""
    scene = studio.empty_scene("Tubes")
    col = scene.collection
    body = mesh_io.new_mesh_object("Body", *shapes.tube_body(resolution), col)
    body.deformrt.role, body.deformrt.layer = "BODY", 0
    studio.material(body, "Skin", (0.85, 0.65, 0.5, 1.0))
    garments = []
    made = shapes.sleeves([radius for _, radius, _ in LAYERS], NOISE, seed, resolution)
    for layer, ((name, _, colour), (gv, gf)) in enumerate(zip(LAYERS, made, strict=True), start=1):
        obj = mesh_io.new_mesh_object(name, gv, gf, col)
        obj.deformrt.role, obj.deformrt.layer = "GARMENT", layer
        studio.material(obj, name, colour)
        garments.append(obj)
    studio.camera_and_lights(scene, target=(0.0, 0.0, 0.3), distance=1.3)
    return body, garments
