"""The scene camera as Cycles frames it: field of view fitted to the sensor, lens shift, and the
render border's window of pixels."""

from typing import NamedTuple

import numpy as np

SUPPORTED = ("PERSP", "ORTHO")


def _fitted_half(cam, width, height):
    """(half the view across the dimension the sensor fits, whether that is the width) for a
    width x height image, as Blender fits the sensor: the tangent of half the field of view for a
    perspective camera, half the orthographic scale (scene units) for an orthographic one."""
    if cam.type not in SUPPORTED:
        raise ValueError(f"DeformRT Layered renders perspective and orthographic cameras, not {cam.type.lower()}: "
                         "render a panoramic camera with Cycles")
    fit = cam.sensor_fit
    if fit == "AUTO":
        fit = "HORIZONTAL" if width >= height else "VERTICAL"
        size = cam.sensor_width  # AUTO fits the sensor width (and the orthographic scale) to the longer side
    else:
        size = cam.sensor_width if fit == "HORIZONTAL" else cam.sensor_height
    half = 0.5 * cam.ortho_scale if cam.type == "ORTHO" else size / (2 * cam.lens)
    return half, fit == "HORIZONTAL"


def vertical_fov(cam, width, height):
    """The camera's vertical field of view for a width x height image (sensor fit as Blender)."""
    half, horizontal = _fitted_half(cam, width, height)
    return 2 * np.arctan(half * height / width if horizontal else half)


def ortho_height(cam, width, height):
    """The height of an orthographic camera's view in scene units for a width x height image."""
    half, horizontal = _fitted_half(cam, width, height)
    return 2 * (half * height / width if horizontal else half)


def image_shift(cam, width, height):
    """The camera's lens shift as an offset of the image's centre on the image plane at distance
    1: Blender's shift_x and shift_y count in whole widths of the fitted dimension."""
    half, _ = _fitted_half(cam, width, height)
    return 2 * half * cam.shift_x, 2 * half * cam.shift_y


class Window(NamedTuple):
    """A rectangle of a frame in pixels, from its bottom left."""

    left: int
    bottom: int
    width: int
    height: int


def render_window(rd, width, height) -> Window:
    """The pixels a render asks for: the render border's when one is on (as Blender rounds it:
    float32 fractions of the frame, truncated), else the whole width x height frame."""
    if not rd.use_border:
        return Window(0, 0, width, height)
    edge = [int(np.float32(f) * np.float32(size)) for f, size in ((rd.border_min_x, width), (rd.border_max_x, width),
                                                                  (rd.border_min_y, height), (rd.border_max_y, height))]
    return Window(edge[0], edge[2], max(edge[1] - edge[0], 0), max(edge[3] - edge[2], 0))
