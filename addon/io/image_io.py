"""PNG files as numpy arrays through Blender's own image loader and writer: what the demo's
contact sheets and the README's pictures are put together from."""

from __future__ import annotations

import bpy
import numpy as np


def read_png(path) -> np.ndarray:
    """(height, width, 4) float32 RGBA of a PNG, the first row the top of the picture."""
    img = bpy.data.images.load(str(path))
    try:
        w, h = img.size
        px = np.empty(w * h * 4, np.float32)
        img.pixels.foreach_get(px)
    finally:
        bpy.data.images.remove(img)
    return px.reshape(h, w, 4)[::-1]  # Blender's rows run bottom-up


def write_png(rgba: np.ndarray, path) -> None:
    """Save (height, width, 4) RGBA in 0..1 (first row the top) as a PNG."""
    h, w = rgba.shape[:2]
    img = bpy.data.images.new("DeformRT picture", w, h, alpha=True)
    try:
        img.pixels.foreach_set(np.ascontiguousarray(rgba[::-1], dtype=np.float32).ravel())
        img.filepath_raw, img.file_format = str(path), "PNG"
        img.save()
    finally:
        bpy.data.images.remove(img)


def contact_sheet(paths, out, columns: int) -> None:
    """Tile equally sized PNGs row by row, first at the top left."""
    tiles = [read_png(p) for p in paths]
    rows = [np.concatenate(tiles[i:i + columns], axis=1) for i in range(0, len(tiles), columns)]
    write_png(np.concatenate(rows, axis=0), out)


__all__ = ["contact_sheet", "read_png", "write_png"]
