"""A real outfit made by artists: MakeHuman's default young female in its CC0 sports suit (top and
leggings) under its casual suit (t-shirt and jeans), each fitted to the body alone with MakeHuman's
own proxy fit, as an MPFB2 user dresses a character (assets/makehuman/, licence beside them). Worn
together they cut through each other and the skin; a Subdivision (viewport 1, render 2) on each
mesh, as MakeHuman's proxies are meant to be seen."""

from pathlib import Path

import numpy as np

from ..addon.io import mesh_io
from . import studio

ASSETS = Path(__file__).parent / "assets" / "makehuman"
OUTFIT = (  # inner to outer: name, file, colour
    ("Sports suit", "female_sportsuit01", (0.12, 0.32, 0.7, 1.0)),
    ("Casual suit", "female_casualsuit01", (0.85, 0.55, 0.15, 1.0)),
)


# MakeHuman's origin is at the hips: the feet of this body go on z = 0, as the other figures'
FLOOR_SHIFT = (0.0, 0.0, 0.81829)


def _arrays(name):
    z = np.load(ASSETS / f"{name}.npz")
    return z["vertices"].astype(np.float64) + FLOOR_SHIFT, z["faces"].astype(np.int64)


def build(seed: int = 0, subdivision: bool = True):
    """Replace the current scene's contents with the outfit; returns (body, garments). ``seed`` is
    unused (the meshes are data): every sample scene builder takes one."""
    scene = studio.empty_scene("MakeHuman")
    col = scene.collection
    body = mesh_io.new_mesh_object("Body", *_arrays("body_female"), col)
    body.deformrt.role, body.deformrt.layer = "BODY", 0
    studio.material(body, "Skin", (0.8, 0.6, 0.48, 1.0), roughness=0.5)
    garments = []
    for layer, (name, stem, colour) in enumerate(OUTFIT, start=1):
        obj = mesh_io.new_mesh_object(name, *_arrays(stem), col)
        obj.deformrt.role, obj.deformrt.layer = "GARMENT", layer
        studio.material(obj, name, colour, roughness=0.8)
        garments.append(obj)
    if subdivision:
        for obj in (body, *garments):
            mod = obj.modifiers.new("Subdivision", "SUBSURF")
            mod.levels, mod.render_levels = 1, 2
    studio.camera_and_lights(scene, target=(0.0, 0.0, 0.85), distance=3.6, elevation_deg=6.0, azimuth_deg=-25.0)
    return body, garments
