"""The jellyfish in Blender: build the 3D animal, keep an optimised stroke on it, and bake
the stroke as shape keys and keyframes (nothing DeformRT-specific is needed to play or
render the result).

The model is built in the 2D simulation's units (a 10 cm bell) times ``scale``. Baking adds
shape keys to the bell, veins and tentacles: "DeformRT Contracted" (the full stroke; the
deformation is linear in it, so its value is the stroke phase), "DeformRT Wobble" (a small
random variation) and, on the bell, "DeformRT Volume" (a normal offset keyed per frame so
the bell keeps its volume); "DeformRT Water 1..k" carry the tentacles with the water the
simulated cycle pushes past them (core.tentacle_drift), a few shapes with keyed weights.
"""

import json

import bpy
import numpy as np

from ...core.jellyfish import bell3d
from ...core.jellyfish.bell import BellShape, Creature
from ...core.jellyfish.keyframes import BellPose, FrameRange, swim_frames
from ...core.jellyfish.swimming import default_config, default_creature, one_cycle, simulate_cycles
from ...core.jellyfish.tentacle_drift import water_drift
from ..io import blender_versions
from ..io.mesh_io import fill_mesh

PROP_MODEL, PROP_STROKE = "deformrt_jellyfish_model", "deformrt_jellyfish_stroke"
KEYS = ("DeformRT Contracted", "DeformRT Wobble", "DeformRT Volume")
WATER_KEY = "DeformRT Water {}"
_OURS = "DeformRT "  # every key DeformRT bakes starts so
BAKE_CYCLES = 6  # simulated in a row for a bake: the bell is cruising by then (docs/REPORT.md)


def mesoglea_material():
    """Glass-like jelly (index 1.34, within the 1.33-1.36 measured for mesoglea) with volume
    absorption, so light through thick parts dims by Beer-Lambert."""
    mat = bpy.data.materials.get("DeformRT Mesoglea")
    if mat is not None:
        return mat
    mat = bpy.data.materials.new("DeformRT Mesoglea")
    blender_versions.use_nodes(mat)
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    bsdf = nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.85, 0.92, 1.0, 1.0)
    bsdf.inputs["Transmission Weight"].default_value = 1.0
    bsdf.inputs["IOR"].default_value = 1.34
    bsdf.inputs["Roughness"].default_value = 0.05
    absorb = nodes.new("ShaderNodeVolumeAbsorption")
    absorb.inputs["Color"].default_value = (0.75, 0.85, 1.0, 1.0)
    absorb.inputs["Density"].default_value = 4.0
    links.new(absorb.outputs["Volume"], nodes["Material Output"].inputs["Volume"])
    return mat


def _tint_material(name, colour, alpha):
    mat = bpy.data.materials.get(name) or bpy.data.materials.new(name)
    blender_versions.use_nodes(mat)
    bsdf = mat.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = colour
    bsdf.inputs["Alpha"].default_value = alpha
    bsdf.inputs["Roughness"].default_value = 0.3
    return mat


def _curve_object(name, polylines, radius, collection, material):
    curve = bpy.data.curves.new(name, "CURVE")
    curve.dimensions = "3D"
    curve.bevel_depth = radius
    curve.bevel_resolution = 2
    for line in polylines:
        spline = curve.splines.new("POLY")
        spline.points.add(len(line) - 1)
        co = np.column_stack([line, np.ones(len(line))])
        spline.points.foreach_set("co", co.ravel())
    curve.materials.append(material)
    obj = bpy.data.objects.new(name, curve)
    collection.objects.link(obj)
    return obj


def add(context, size: float, anatomy: bell3d.Anatomy):
    """The bell (mesh) ``size`` across, its veins and tentacles (curves, parented to it) at the
    3D cursor."""
    shape = BellShape()
    scale = size / shape.diameter
    model = bell3d.build(shape, anatomy)
    segments, veins, tentacles = anatomy.segments, anatomy.veins, anatomy.tentacles
    col = context.collection
    mesh = bpy.data.meshes.new("Jellyfish")
    fill_mesh(mesh, model.verts * scale, model.faces)
    mesh.shade_smooth()
    mesh.materials.append(mesoglea_material())
    bell = bpy.data.objects.new("Jellyfish", mesh)
    col.objects.link(bell)
    bell.location = context.scene.cursor.location
    bell[PROP_MODEL] = json.dumps({"scale": scale, "bell_vertices": model.bell_vertices, "segments": segments})
    parts = []
    if veins:
        parts.append(_curve_object("Jellyfish Veins", [v * scale for v in model.veins], 0.004 * size, col,
                                   _tint_material("DeformRT Veins", (0.95, 0.55, 0.7, 1.0), 0.8)))
    if tentacles:
        parts.append(_curve_object("Jellyfish Tentacles", [t * scale for t in model.tentacles], 0.003 * size, col,
                                   _tint_material("DeformRT Tentacles", (0.95, 0.8, 0.85, 1.0), 0.6)))
    for p in parts:
        p.parent = bell
    return bell


def jellyfish_of(obj):
    """The bell object for a bell or one of its parts, else None."""
    while obj is not None and PROP_MODEL not in obj:
        obj = obj.parent
    return obj


def store_stroke(bell, result, config) -> dict:
    """Keep an optimisation's best creature and its cycle on the bell; returns what was kept."""
    c = result.creature
    cycles = max(len(result.cycle.path_per_cycle_m), 1)
    stored = {
        # what the panel says: bell diameters a cycle, and the wake's energy against the default stroke's
        "diameters_per_cycle": result.cycle.path_m / cycles / config.bell.diameter,
        "energy_share": result.cycle.energy_loss / result.scales.energy,
        "method": result.method, "fitness": result.fitness, "evaluations": result.evaluations,
        "stopped": result.stopped, "controls": c.controls.tolist(), "destinations": c.destinations.tolist(),
        "contraction": c.contraction, "path_m": result.cycle.path_m, "speed": result.cycle.speed.tolist(),
        "period": config.period, "particles": config.particles, "fluid": config.fluid, "viscosity": config.viscosity,
        "weights": list(config.weights)}
    bell[PROP_STROKE] = json.dumps(stored)
    return stored


# Optimize Stroke's Resolution allows 20-400 particles a side (an odd count rounded up); a stroke
# read from a file with more would make Bake Swimming allocate gigabytes (30,000: 6.2 GB in 15 s)
PARTICLES = (20, 400)
# and its Water Viscosity 1e-7 to 1e-2 m^2/s (from a tenth of water's to syrup's)
VISCOSITY = (1e-7, 1e-2)


def stroke_of(bell):
    """(creature, the config it was found with, True) stored on the bell, or the default
    creature on a coarse lattice and False when nothing was optimised yet. A stored stroke the
    panel could not have made (a damaged or crafted file) raises ValueError naming the bell."""
    if PROP_STROKE in bell:
        try:
            s = json.loads(bell[PROP_STROKE])
            particles = s["particles"]
            if not isinstance(particles, int) or not PARTICLES[0] <= particles <= PARTICLES[1]:
                raise ValueError(f"{particles!r} particles a side, outside {PARTICLES[0]}-{PARTICLES[1]}")
            controls, destinations = np.array(s["controls"], float), np.array(s["destinations"], float)
            if not (np.isfinite(controls).all() and np.isfinite(destinations).all()):
                raise ValueError("control points that are not numbers")
            creature = Creature(controls, destinations, float(s["contraction"]))
            # strokes stored before the water of revolution were found in the planar water
            viscosity = float(s.get("viscosity", default_config().viscosity))
            if not VISCOSITY[0] <= viscosity <= VISCOSITY[1]:
                raise ValueError(f"a viscosity of {viscosity!r} m^2/s, outside {VISCOSITY[0]:g}-{VISCOSITY[1]:g}")
            config = default_config(particles=particles, period=float(s["period"]), fluid=s.get("fluid", "planar"),
                                    viscosity=viscosity)
        except (ValueError, KeyError, TypeError) as exc:
            raise ValueError(f"{bell.name}'s stored stroke is damaged ({exc}): run Optimize Stroke again") from None
        return creature, config, True
    cfg = default_config(particles=60)
    return default_creature(cfg), cfg, False


def stroke_line(bell) -> str | None:
    """What the panel says of the bell's stored stroke (None: none stored); a damaged one is said
    to be damaged, not raised on every redraw."""
    if PROP_STROKE not in bell:
        return None
    try:
        s = json.loads(bell[PROP_STROKE])
        if "diameters_per_cycle" not in s:  # stored by an older DeformRT
            return f"Stroke: optimized in {int(s['evaluations'])} trial cycles"
        return (f"Stroke: {float(s['diameters_per_cycle']):.3f} bell diameters a cycle, wake energy "
                f"{100 * float(s['energy_share']):.0f}% of the default stroke's")
    except (ValueError, KeyError, TypeError):
        return "Stroke: the stored values are damaged (run Optimize Stroke again)"


def _points(obj):
    if obj.type == "MESH":
        co = np.empty(len(obj.data.vertices) * 3)
        obj.data.vertices.foreach_get("co", co)
        return co.reshape(-1, 3)
    pts = []
    for spline in obj.data.splines:
        co = np.empty(len(spline.points) * 4)
        spline.points.foreach_get("co", co)
        pts.append(co.reshape(-1, 4)[:, :3])
    return np.vstack(pts)


def _set_key(obj, name, co, lo=-10.0, hi=10.0):
    if obj.data.shape_keys is None:
        obj.shape_key_add(name="Basis", from_mix=False)
    key = obj.data.shape_keys.key_blocks.get(name) or obj.shape_key_add(name=name, from_mix=False)
    key.slider_min, key.slider_max = lo, hi
    key.data.foreach_set("co", np.asarray(co, np.float32).ravel())
    return key


def clear_bake(bell):
    """Remove DeformRT's keys and their keyframes from the bell and its parts, and the bell's
    swim keyframes (Basis goes too unless the user has keys of their own)."""
    for obj in (bell, *bell.children):
        keys = obj.data.shape_keys if obj.type in {"MESH", "CURVE"} else None
        if keys is None:
            continue
        _remove_curves(keys, lambda f: f'key_blocks["{_OURS}' in f.data_path)
        for block in [b for b in keys.key_blocks if b.name.startswith(_OURS)]:
            obj.shape_key_remove(block)
        if len(keys.key_blocks) == 1:
            obj.shape_key_remove(keys.key_blocks[0])
    _remove_curves(bell, lambda f: f.data_path == "location" and f.array_index == 2)


def _fcurves(id_data):
    """The F-curves animating ``id_data``: from Blender 4.4 one action can animate several
    data-blocks (the bell and its shape keys share one), each in its own slot."""
    ad = id_data.animation_data
    if ad is None or ad.action is None:
        return None
    slot = getattr(ad, "action_slot", None)
    if slot is None:
        return ad.action.fcurves
    from bpy_extras import anim_utils

    bag = anim_utils.action_get_channelbag_for_slot(ad.action, slot)
    return bag.fcurves if bag is not None else None


def _remove_curves(id_data, match):
    fcurves = _fcurves(id_data)
    for fc in [f for f in (fcurves or ()) if match(f)]:
        fcurves.remove(fc)


def _water_keys(obj, drift, scale):
    """Shape keys for the drift's shapes on a curve's points (radial and axial turned to the
    point's angle); each shape is sized so its keyed value, as simulated, stays within [-1, 1]."""
    p = _points(obj) / scale
    phi = np.arctan2(p[:, 1], p[:, 0])
    peaks = np.maximum(np.abs(drift.weights).max(axis=1), 1e-300)
    for k, (shape, peak) in enumerate(zip(drift.shapes, peaks, strict=True)):
        move = np.column_stack([shape[:, 0] * np.cos(phi), shape[:, 0] * np.sin(phi), shape[:, 1]]) * peak
        _set_key(obj, WATER_KEY.format(k + 1), (p + move) * scale)
    return peaks


def bake(scene, bell, frames: FrameRange, wobble=0.03, seed=0, water=1.0):
    """Keys and keyframes for the stored stroke over ``frames``; ``water`` scales the tentacles'
    drift with the water (1 is as simulated). Returns a summary line."""
    if frames.end < frames.start:
        raise ValueError(f"the frame range is empty ({frames.start}-{frames.end})")
    if frames.cycle_frames < 2:
        raise ValueError("a cycle needs at least 2 frames")
    if not (np.isfinite(water) and water >= 0):
        raise ValueError(f"the water drift scale must be >= 0, got {water}")
    info = json.loads(bell[PROP_MODEL])
    scale, n_bell = info["scale"], info["bell_vertices"]
    creature, config, optimised = stroke_of(bell)
    # the stored stroke is replayed (deterministic) cycle after cycle from rest, as many as the frames
    # hold (up to BAKE_CYCLES; the last repeats after), and the water of its last cycle moves the tentacles
    count = int(min(BAKE_CYCLES, max(1, np.ceil((frames.end - frames.start + 1) / frames.cycle_frames))))
    cycle = simulate_cycles(creature, config, count, sample_fields=True)
    if not np.isfinite(cycle.fitness):
        raise ValueError(f"the stored stroke cannot swim: {cycle.reason}")
    water_cycle = one_cycle(cycle, count - 1)
    box_half = 0.5 * config.box
    field = bell3d.StrokeField(config.bell, creature, box_half)
    rng = np.random.default_rng(seed)
    jitter = wobble * 0.5 * config.bell.diameter * rng.standard_normal((field.control_count, 3))
    wobble_field = bell3d.StrokeField(config.bell, Creature(creature.controls, creature.controls, 0.5), box_half,
                                      jitter=jitter)
    clear_bake(bell)
    pose = _bell_keys(bell, (field, wobble_field), config.bell, scale, n_bell)
    drifts = {}
    parts = [c for c in bell.children if c.type == "CURVE"]
    for child in parts:
        p = _points(child) / scale
        _set_key(child, KEYS[0], (p + field(p)) * scale)
        _set_key(child, KEYS[1], (p + wobble_field(p)) * scale)
        if water > 0 and (p[:, 2] < 0).any():  # tentacles hang below the margin, veins do not
            drift = water_drift(water_cycle, config, np.column_stack([np.hypot(p[:, 0], p[:, 1]), p[:, 2]]))
            drifts[child.name] = (drift, _water_keys(child, drift, scale))
    _keyframe(bell, parts, drifts, swim_frames(cycle, creature, frames, pose, seed), water, scale)
    scene.frame_set(scene.frame_current)
    source = "the optimized stroke" if optimised else "the default stroke (nothing optimized yet)"
    per_cycle = cycle.path_per_cycle_m / config.bell.diameter
    later = f", {per_cycle[-1]:.3f} in cycle {count} and each after" if count > 1 else ""
    return (f"Baked {frames.end - frames.start + 1} frames of {source}: {per_cycle[0]:.3f} bell diameters in the "
            f"first {frames.cycle_frames}-frame cycle{later}")


def _bell_keys(bell, fields, shape, scale, n_bell) -> BellPose:
    """The bell's contracted, wobbled and thickened keys; returns its pose for the keyframes."""
    field, wobble_field = fields
    rest = _points(bell) / scale
    bell_faces = bell3d.triangles([tuple(p.vertices) for p in bell.data.polygons if max(p.vertices) < n_bell])
    normals = np.zeros_like(rest)
    normals[:n_bell] = bell3d.vertex_normals(rest[:n_bell], bell_faces)
    thickness = shape.height - shape.inner_height
    moved, wob = field(rest), wobble_field(rest)
    _set_key(bell, KEYS[0], (rest + moved) * scale)
    _set_key(bell, KEYS[1], (rest + wob) * scale)
    _set_key(bell, KEYS[2], (rest + thickness * normals) * scale)
    return BellPose(rest[:n_bell], moved[:n_bell], wob[:n_bell], bell_faces, normals[:n_bell], thickness)


def _keyframe(bell, parts, drifts, swim, water, scale) -> None:
    """Key values and the bell's rise at every frame of ``swim``; each part's water keys from its
    drift (``drifts``: name -> (drift, peaks))."""
    z0 = bell.location.z
    for f in swim:
        for obj, values in ((bell, {KEYS[0]: f.contraction, KEYS[1]: f.wobble, KEYS[2]: f.volume}),
                            *((c, {KEYS[0]: f.contraction, KEYS[1]: f.wobble}) for c in parts)):
            if obj.name in drifts:
                drift, peaks = drifts[obj.name]
                for k, v in enumerate(water * drift.weights_at(f.tau) / peaks):
                    values[WATER_KEY.format(k + 1)] = float(v)
            blocks = obj.data.shape_keys.key_blocks
            for name, v in values.items():
                blocks[name].value = v
                blocks[name].keyframe_insert("value", frame=f.frame)
        bell.location.z = z0 + f.rise_m * scale
        bell.keyframe_insert("location", index=2, frame=f.frame)
    bell.location.z = z0
