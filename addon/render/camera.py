"""The scene camera as Cycles frames it: field of view fitted to the sensor, lens shift, and the
render border's window of pixels."""

import numpy as np


def _fitted_half(cam, width, height):
    """(tan of half the field of view across the dimension the sensor fits, whether that is the
    width) for a width x height image, as Blender fits the sensor."""
    if cam.type != "PERSP":
        raise ValueError(f"DeformRT Layered renders perspective cameras only, not {cam.type.lower()}")
    fit = cam.sensor_fit
    if fit == "AUTO":
        fit = "HORIZONTAL" if width >= height else "VERTICAL"
        half = cam.sensor_width / (2 * cam.lens)  # AUTO fits the sensor width to the longer side
    else:
        half = (cam.sensor_width if fit == "HORIZONTAL" else cam.sensor_height) / (2 * cam.lens)
    return half, fit == "HORIZONTAL"


def vertical_fov(cam, width, height):
    """The camera's vertical field of view for a width x height image (sensor fit as Blender)."""
    half, horizontal = _fitted_half(cam, width, height)
    return 2 * np.arctan(half * height / width if horizontal else half)


def image_shift(cam, width, height):
    """The camera's lens shift as an offset of the image's centre on the image plane at distance
    1: Blender's shift_x and shift_y count in whole widths of the fitted dimension."""
    half, _ = _fitted_half(cam, width, height)
    return 2 * half * cam.shift_x, 2 * half * cam.shift_y


def render_window(rd, width, height):
    """(left, bottom, width, height) in pixels of what a render asks for: the render border's
    pixels when one is on (as Blender rounds it: float32 fractions of the frame, truncated), else
    the whole width x height frame."""
    if not rd.use_border:
        return 0, 0, width, height
    edge = [int(np.float32(f) * np.float32(size)) for f, size in ((rd.border_min_x, width), (rd.border_max_x, width),
                                                                  (rd.border_min_y, height), (rd.border_max_y, height))]
    return edge[0], edge[2], max(edge[1] - edge[0], 0), max(edge[3] - edge[2], 0)
