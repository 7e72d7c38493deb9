"""The Python API differences between the Blender versions DeformRT runs in (4.2 LTS to 5.2 LTS),
each read from the running Blender's own RNA rather than from its version number where it can be:
one place to look when a new Blender moves something."""

import bpy

# A PropertyGroup property with a Python callback (update, get, set), registered even once, makes
# the Blender 4.2 and 4.3 Python module crash on exit (in the SpaceType destructor, after Python has
# shut down; 4.4-5.2 exit cleanly). There, what such a callback would do is done when it is noticed.
PROPERTY_CALLBACKS = bpy.app.version >= (4, 4, 0)

# 5.0 made materials and worlds always node-based and deprecated their switch (removed in 6.0)
_NODES_SWITCH = bpy.app.version < (5, 0, 0)


def use_nodes(idblock) -> None:
    """Give a material or world its node tree (4.x needs the switch on; 5.x always has one)."""
    if _NODES_SWITCH:
        idblock.use_nodes = True


def uses_nodes(idblock) -> bool:
    return idblock.node_tree is not None and (not _NODES_SWITCH or idblock.use_nodes)


def light_power(light) -> float:
    """A light's strength times 2^exposure (4.4 added exposure; before it, 2^0)."""
    return light.energy * 2.0 ** getattr(light, "exposure", 0.0)


def light_tint(light):
    """The blackbody colour of a light's temperature when it uses one (4.4+), else None."""
    return tuple(light.temperature_color) if getattr(light, "use_temperature", False) else None


def path_options() -> set:
    """Options for a file-path property: '//'-relative paths where this Blender marks them (4.5+)."""
    if "is_path_supports_blend_relative" in bpy.types.Property.bl_rna.properties:
        return {"PATH_SUPPORTS_BLEND_RELATIVE"}
    return set()


def operator_arguments(operator, **arguments) -> dict:
    """The arguments this Blender's operator takes (5.0 dropped some of the Alembic exporter's)."""
    known = operator.get_rna_type().properties.keys()
    return {k: v for k, v in arguments.items() if k in known}


# 5.1 moved a Geometry Nodes modifier's input values from ID properties (mod["Socket_1"]) to typed
# RNA (mod.properties.inputs.Socket_1.value)
_TYPED_INPUTS = "properties" in bpy.types.NodesModifier.bl_rna.properties


def modifier_input(mod, identifier):
    """The value of a Geometry Nodes modifier's input (by socket identifier), or None."""
    if _TYPED_INPUTS:
        item = getattr(mod.properties.inputs, identifier, None)
        return None if item is None else item.value
    return mod.get(identifier)


def set_modifier_input(mod, identifier, value) -> None:
    if _TYPED_INPUTS:
        getattr(mod.properties.inputs, identifier).value = value
    else:
        mod[identifier] = value


def modifier_inputs(mod) -> dict:
    """Every input value of a Geometry Nodes modifier, by socket identifier."""
    if _TYPED_INPUTS:
        inputs = mod.properties.inputs
        names = [p.identifier for p in inputs.bl_rna.properties if p.identifier not in ("rna_type", "name")]
        return {k: getattr(inputs, k).value for k in names}
    return {k: mod[k] for k in mod.keys()}
