"""Lights and the world as DeformRT Layered takes them: sun, point, spot and area lights at the
power Blender gives them, divided by pi on the way in (the thesis' Lambert term has no 1/pi),
and the world's colour as ambient light."""

import numpy as np

from ...core.render.lighting import Light
from ..io import blender_versions


def lights(depsgraph, area_samples=4):
    out = []
    for inst in depsgraph.object_instances:
        obj = inst.object
        if obj.type != "LIGHT":
            continue
        m = np.array(inst.matrix_world)
        light = obj.data
        # a Lambert surface sends E albedo / pi; power as Blender takes it: colour (times the
        # blackbody colour of its temperature when that is on) x strength x 2^exposure
        colour = np.array(light.color) * blender_versions.light_power(light) / np.pi
        tint = blender_versions.light_tint(light)
        if tint is not None:
            colour = colour * np.array(tint)
        if light.type == "SUN":
            out.append(Light("SUN", tuple(-m[:3, 2]), tuple(colour), shadow=light.use_shadow))
        elif light.type == "POINT":
            # a point lamp of P watts sends P / (4 pi) per steradian
            out.append(Light("POINT", tuple(m[:3, 3]), tuple(colour / (4 * np.pi)), shadow=light.use_shadow))
        elif light.type == "SPOT":
            # as bright as a point lamp of its power inside its cone, which points down its local -z
            out.append(Light("SPOT", tuple(m[:3, 3]), tuple(colour / (4 * np.pi)), axis=tuple(-m[:3, 2]),
                             spot_size=float(light.spot_size), spot_blend=float(light.spot_blend),
                             shadow=light.use_shadow))
        elif light.type == "AREA":
            # P watts off a Lambertian patch: P / pi per steradian along its normal (local -z)
            sx = light.size
            sy = light.size if light.shape in ("SQUARE", "DISK") else light.size_y
            u, v = m[:3, 0] * sx / 2, -m[:3, 1] * sy / 2  # u x v = -z: the side it lights
            disk = light.shape in ("DISK", "ELLIPSE")
            if not light.normalize:  # its strength is per square metre: the power grows with its area
                colour = colour * float(np.linalg.norm(np.cross(u, v))) * (np.pi if disk else 4.0)
            out.append(Light("AREA", tuple(m[:3, 3]), tuple(colour / np.pi), edges=(tuple(u), tuple(v)),
                             disk=disk, samples=area_samples, shadow=light.use_shadow))
    return out


def world_colour(world):
    if world is not None and blender_versions.uses_nodes(world) and "Background" in world.node_tree.nodes:
        node = world.node_tree.nodes["Background"]
        return tuple(np.array(node.inputs["Color"].default_value[:3]) * node.inputs["Strength"].default_value)
    return tuple(world.color) if world is not None else (0.05, 0.05, 0.05)
