"""The Geometry Nodes group that shows a garment's resolved layering without touching its mesh.

The group sits in the garment's modifier stack where viewport and render see the same vertices
(``result_stack``). It reads the correction from a small data object (offsets per vertex, a
hidden flag per face, both stored by index) and applies it to what the stack above produced, so
the garment keeps its own materials, UVs, modifiers and edit history; switching the modifier
off shows it as fitted. A correction is never applied to a mesh it was not made for: when the
incoming mesh has another number of points or faces than the one resolved (vertices added or
deleted, a modifier above changed), the group passes it through unchanged, with or without the
add-on installed.
"""

import bpy

from ..io import blender_versions

GROUP_NAME = "DeformRT Result"
# Bump when the node layout changes: files saved with an older group get it rebuilt.
GROUP_VERSION = 4
OFFSET_ATTRIBUTE = "deformrt_offset"
HIDDEN_ATTRIBUTE = "deformrt_hidden"
# True on the data object's points: pass the stack's own geometry through. A flag in the data
# rather than the modifier's visibility or an input of its own, because the garment then
# evaluates again as a dependent of the data (about 1 ms) and not as an edited object, which
# makes its cloth modifier start over (about 5 ms a garment). Absent (older data): shown.
BYPASS_ATTRIBUTE = "deformrt_bypass"
DATA_SOCKET = "Result Data"
# The point and face counts of the mesh the correction was made for (on every data point).
# Absent in data written before version 3: then no count is checked, as before.
POINT_COUNT_ATTRIBUTE = "deformrt_point_count"
FACE_COUNT_ATTRIBUTE = "deformrt_face_count"
COUNTS_KNOWN_ATTRIBUTE = "deformrt_counts_known"
# Where each vertex was when the correction was made (object space), and how far it may be now:
# a mesh whose vertices moved since (a value in a node group above, a lattice, a hook, a driver:
# anything the stack above does) is passed through, whatever moved it. Absent (older data): not
# checked. The output carries FITS_ATTRIBUTE (whether the vertices are where they were) for the
# add-on to say so.
CAGE_ATTRIBUTE = "deformrt_cage"
CAGE_TOLERANCE_ATTRIBUTE = "deformrt_cage_tolerance"
CAGE_KNOWN_ATTRIBUTE = "deformrt_cage_known"
FITS_ATTRIBUTE = "deformrt_fits"


def _build(group):
    group.interface.clear()
    group.nodes.clear()
    group.interface.new_socket(name="Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
    group.interface.new_socket(name=DATA_SOCKET, in_out="INPUT", socket_type="NodeSocketObject")
    group.interface.new_socket(name="Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    g = _Graph(group)
    move = g.new("GeometryNodeSetPosition")
    g.link(g.inputs.outputs["Geometry"], move.inputs["Geometry"])
    g.link(g.sampled(OFFSET_ATTRIBUTE, "FLOAT_VECTOR"), move.inputs["Offset"])
    drop = g.new("GeometryNodeDeleteGeometry")
    drop.domain = "FACE"
    g.link(move.outputs["Geometry"], drop.inputs["Geometry"])
    g.link(g.sampled(HIDDEN_ATTRIBUTE, "BOOLEAN"), drop.inputs["Selection"])
    elsewhere = g.logic("OR", _other_mesh(g), _moved_off_cage(g))
    switch = g.new("GeometryNodeSwitch")
    switch.input_type = "GEOMETRY"
    g.link(g.logic("OR", g.sampled(BYPASS_ATTRIBUTE, "BOOLEAN", per_point=False), elsewhere), switch.inputs["Switch"])
    g.link(drop.outputs["Geometry"], switch.inputs["False"])
    g.link(g.inputs.outputs["Geometry"], switch.inputs["True"])
    fits = g.new("FunctionNodeBooleanMath")
    fits.operation = "NOT"
    g.link(elsewhere, fits.inputs[0])
    store = g.new("GeometryNodeStoreNamedAttribute")
    store.data_type, store.domain = "BOOLEAN", "POINT"
    store.inputs["Name"].default_value = FITS_ATTRIBUTE
    g.link(switch.outputs["Output"], store.inputs["Geometry"])
    g.link(fits.outputs[0], store.inputs["Value"])
    g.link(store.outputs["Geometry"], g.output.inputs["Geometry"])
    for i, node in enumerate((g.inputs, g.info, g.index, move, drop, switch, store, g.output)):
        node.location = (220 * i, 0)
    group["deformrt_version"] = GROUP_VERSION


class _Graph:
    """The group's nodes being built: its input and output, the data object's geometry, and the
    two node patterns every test of the result uses."""

    def __init__(self, group):
        self.nodes, self.links = group.nodes, group.links
        self.inputs, self.output = self.new("NodeGroupInput"), self.new("NodeGroupOutput")
        self.info = self.new("GeometryNodeObjectInfo")
        self.info.transform_space = "ORIGINAL"
        self.link(self.inputs.outputs[DATA_SOCKET], self.info.inputs["Object"])
        self.index = self.new("GeometryNodeInputIndex")

    def new(self, kind):
        return self.nodes.new(kind)

    def link(self, a, b):
        self.links.new(a, b)

    def sampled(self, attribute, data_type, per_point=True):
        """The data object's attribute at each point (else point 0's: one value, as a switch
        between geometries needs)."""
        named = self.new("GeometryNodeInputNamedAttribute")
        named.data_type = data_type
        named.inputs["Name"].default_value = attribute
        sample = self.new("GeometryNodeSampleIndex")
        sample.data_type, sample.domain = data_type, "POINT"
        self.link(self.info.outputs["Geometry"], sample.inputs["Geometry"])
        self.link(named.outputs["Attribute"], sample.inputs["Value"])
        if per_point:
            self.link(self.index.outputs["Index"], sample.inputs["Index"])
        return sample.outputs["Value"]

    def logic(self, operation, a, b):
        node = self.new("FunctionNodeBooleanMath")
        node.operation = operation
        self.link(a, node.inputs[0])
        self.link(b, node.inputs[1])
        return node.outputs[0]


def _other_mesh(g):
    """Whether the mesh has other point or face counts than the one resolved (when known)."""
    size = g.new("GeometryNodeAttributeDomainSize")
    size.component = "MESH"
    g.link(g.inputs.outputs["Geometry"], size.inputs["Geometry"])
    differ = []
    for count, attribute in (("Point Count", POINT_COUNT_ATTRIBUTE), ("Face Count", FACE_COUNT_ATTRIBUTE)):
        compare = g.new("FunctionNodeCompare")
        compare.data_type, compare.operation = "INT", "NOT_EQUAL"
        # the integer pair: its own sockets up to 4.5 (A_INT, B_INT), typed A and B from 5.0
        a, b = [s for s in compare.inputs if s.enabled][:2]
        g.link(size.outputs[count], a)
        g.link(g.sampled(attribute, "INT", per_point=False), b)
        differ.append(compare.outputs[0])
    return g.logic("AND", g.sampled(COUNTS_KNOWN_ATTRIBUTE, "BOOLEAN", per_point=False), g.logic("OR", *differ))


def _moved_off_cage(g):
    """Whether any vertex is farther than the tolerance from where it was resolved (when known)."""
    apart = g.new("ShaderNodeVectorMath")
    apart.operation = "DISTANCE"
    g.link(g.new("GeometryNodeInputPosition").outputs["Position"], apart.inputs[0])
    g.link(g.sampled(CAGE_ATTRIBUTE, "FLOAT_VECTOR"), apart.inputs[1])
    farthest = g.new("GeometryNodeAttributeStatistic")
    farthest.data_type, farthest.domain = "FLOAT", "POINT"
    g.link(g.inputs.outputs["Geometry"], farthest.inputs["Geometry"])
    g.link(apart.outputs["Value"], farthest.inputs["Attribute"])
    beyond = g.new("FunctionNodeCompare")
    beyond.data_type, beyond.operation = "FLOAT", "GREATER_THAN"
    g.link(farthest.outputs["Max"], beyond.inputs["A"])
    g.link(g.sampled(CAGE_TOLERANCE_ATTRIBUTE, "FLOAT", per_point=False), beyond.inputs["B"])
    return g.logic("AND", g.sampled(CAGE_KNOWN_ATTRIBUTE, "BOOLEAN", per_point=False), beyond.outputs["Result"])


def is_our_group(group) -> bool:
    return group is not None and (group.name == GROUP_NAME or "deformrt_version" in group)


def node_group():
    """The shared group, built on first use (or rebuilt when it is from another version)."""
    group = bpy.data.node_groups.get(GROUP_NAME)
    if group is None or group.bl_idname != "GeometryNodeTree":
        group = bpy.data.node_groups.new(GROUP_NAME, "GeometryNodeTree")
    if group.get("deformrt_version") != GROUP_VERSION:
        # a rebuilt interface gets new socket identifiers: the garments' data links move over
        try:
            old = data_socket_id(group)
        except RuntimeError:
            old = None
        users = [(o, m, blender_versions.modifier_input(m, old)) for o in bpy.data.objects
                 for m in getattr(o, "modifiers", ())
                 if old is not None and m.type == "NODES" and m.node_group == group]
        _build(group)
        new = data_socket_id(group)
        for obj, mod, data in users:
            if data is not None:
                blender_versions.set_modifier_input(mod, new, data)
                obj.update_tag()
    return group


def data_socket_id(group) -> str:
    """The modifier key of the data-object input (Blender names it ``Socket_<n>``)."""
    for item in group.interface.items_tree:
        if item.item_type == "SOCKET" and item.in_out == "INPUT" and item.name == DATA_SOCKET:
            return item.identifier
    raise RuntimeError(f"node group {group.name!r} has no {DATA_SOCKET!r} input")
