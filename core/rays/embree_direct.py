"""Triangle geometry handed to Embree without copying, and moved in place.

embreex builds a mesh by copying it vertex by vertex through Python-level array indexing:
about 0.9 us per triangle, five times what Embree's own BVH build then takes, and it has no
way to move a mesh. Here the same Embree library that embreex loaded is called through
ctypes: the geometry shares numpy buffers (rtcSetSharedGeometryBuffer), and a deforming mesh
is written in place and committed again instead of being made anew. Some of a mesh's
triangles can also be made an Embree scene of their own (a ``Group``) and instanced into
an embreex scene: several scenes over overlapping sets of one mesh's triangles then build
each triangle once. Tracing stays with embreex, on the very scene embreex made.

This reads the scene handle out of embreex's EmbreeScene object, so it checks the object
layout it relies on (and that a ray really hits what it attached) once per process. Anything
unexpected turns it off and RayScene falls back to embreex's own constructor.
"""

from __future__ import annotations

import ctypes
import glob
import os

import numpy as np

_RTC_GEOMETRY_TYPE_TRIANGLE = 0
_RTC_GEOMETRY_TYPE_INSTANCE = 121
_RTC_SCENE_FLAG_ROBUST = 1 << 2
_RTC_BUFFER_TYPE_INDEX = 0
_RTC_BUFFER_TYPE_VERTEX = 1
_RTC_FORMAT_UINT3 = 0x5003
_RTC_FORMAT_FLOAT3 = 0x9003
_RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR = 0x9234
# Embree's build qualities (RTCBuildQuality)
QUALITY = {"low": 0, "medium": 1, "high": 2}
_IDENTITY = np.array([1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0], np.float32)  # 3x4, column by column

_lib = None
_scene_offset = None
_state = "unchecked"  # "on" or "off" after the first check


def _load_library():
    import embreex

    here = os.path.dirname(embreex.__file__)
    patterns = ("*embree4*.so*", "*embree4*.dylib", "*embree4*.dll")
    # wheels keep the bundled library beside the package (auditwheel, delvewheel) or inside it (delocate)
    folders = (os.path.join(here, "..", "embreex.libs"), os.path.join(here, ".dylibs"), here)
    for folder in folders:
        for pattern in patterns:
            found = sorted(glob.glob(os.path.join(folder, pattern)))
            if found:
                lib = ctypes.CDLL(os.path.abspath(found[0]))
                vp, u32, sz = ctypes.c_void_p, ctypes.c_uint, ctypes.c_size_t
                signatures = {
                    "rtcGetSceneDevice": (vp, [vp]),
                    "rtcNewGeometry": (vp, [vp, ctypes.c_int]),
                    "rtcSetSharedGeometryBuffer": (None, [vp, ctypes.c_int, u32, ctypes.c_int, vp, sz, sz, sz]),
                    "rtcUpdateGeometryBuffer": (None, [vp, ctypes.c_int, u32]),
                    "rtcCommitGeometry": (None, [vp]),
                    "rtcAttachGeometry": (u32, [vp, vp]),
                    "rtcReleaseGeometry": (None, [vp]),
                    "rtcAttachGeometryByID": (None, [vp, vp, u32]),
                    "rtcNewScene": (vp, [vp]),
                    "rtcSetSceneFlags": (None, [vp, ctypes.c_int]),
                    "rtcSetSceneBuildQuality": (None, [vp, ctypes.c_int]),
                    "rtcSetGeometryBuildQuality": (None, [vp, ctypes.c_int]),
                    "rtcCommitScene": (None, [vp]),
                    "rtcReleaseScene": (None, [vp]),
                    "rtcSetGeometryInstancedScene": (None, [vp, vp]),
                    "rtcSetGeometryTransform": (None, [vp, u32, ctypes.c_int, vp]),
                }
                for name, (res, args) in signatures.items():
                    fn = getattr(lib, name)
                    fn.restype, fn.argtypes = res, args
                return lib
    return None


def _find_scene_offset(scene) -> int | None:
    """Byte offset of the RTCScene handle in an (empty, uncommitted) EmbreeScene: the pointer
    just before its public ``is_committed`` int (the field order of embreex's rtcore_scene.pxd)."""
    words = (ctypes.c_uint64 * (type(scene).__basicsize__ // 8)).from_address(id(scene))
    scene.is_committed = 0x5A17C0DE
    hits = [i for i in range(len(words)) if words[i] & 0xFFFFFFFF == 0x5A17C0DE]
    scene.is_committed = 0
    if len(hits) != 1 or hits[0] < 3 or not words[hits[0] - 1]:  # refcount, type, then the handle
        return None
    return (hits[0] - 1) * 8


class Triangles:
    """One triangle mesh attached to an embreex EmbreeScene, sharing float32 vertex and
    uint32 index buffers with Embree. ``move(vertices)`` writes new positions in place (Embree then
    builds the BVH again on the next ray). ``quality``: the BVH's build quality (``QUALITY``), the
    mesh's and the scene's."""

    def __init__(self, scene, vertices, faces, quality="medium"):
        device = _lib.rtcGetSceneDevice(_handle(scene))
        self._scene, self._device = scene, device
        # Embree reads vertices as 16-byte loads: one float of padding past the last vertex
        self._vbuf = np.zeros(3 * len(vertices) + 1, np.float32)
        self.vertices = self._vbuf[:-1].reshape(-1, 3)
        self.vertices[:] = vertices
        self._faces = np.ascontiguousarray(faces, dtype=np.uint32)
        geom = _lib.rtcNewGeometry(device, _RTC_GEOMETRY_TYPE_TRIANGLE)
        if not geom:
            raise RuntimeError("Embree could not make a triangle geometry")
        _lib.rtcSetSharedGeometryBuffer(geom, _RTC_BUFFER_TYPE_VERTEX, 0, _RTC_FORMAT_FLOAT3,
                                        self._vbuf.ctypes.data, 0, 12, len(self.vertices))
        _lib.rtcSetSharedGeometryBuffer(geom, _RTC_BUFFER_TYPE_INDEX, 0, _RTC_FORMAT_UINT3,
                                        self._faces.ctypes.data, 0, 12, len(self._faces))
        self.quality = quality
        _lib.rtcSetGeometryBuildQuality(geom, QUALITY[quality])
        _lib.rtcSetSceneBuildQuality(_handle(scene), QUALITY[quality])
        _lib.rtcCommitGeometry(geom)
        _lib.rtcAttachGeometry(_handle(scene), geom)
        self._geom = geom  # the scene holds the reference from here on
        _lib.rtcReleaseGeometry(geom)

    def move(self, vertices) -> None:
        self.vertices[:] = vertices
        _lib.rtcUpdateGeometryBuffer(self._geom, _RTC_BUFFER_TYPE_VERTEX, 0)
        _lib.rtcCommitGeometry(self._geom)
        self._scene.is_committed = 0  # embreex commits the scene again before the next ray


class Group:
    """Faces ``start..stop-1`` of a ``Triangles`` mesh as an Embree scene of their own, built
    now, sharing the mesh's buffers. Its one geometry has the ID ``geom_id``, which a hit
    through an instance of it reports as its geomID. The mesh must not move while the group
    is used: the group's BVH is not built again."""

    def __init__(self, mesh: Triangles, start: int, stop: int, geom_id: int):
        self._mesh = mesh  # holds the shared buffers
        self.handle = _lib.rtcNewScene(mesh._device)
        if not self.handle:
            raise RuntimeError("Embree could not make a scene")
        _lib.rtcSetSceneFlags(self.handle, _RTC_SCENE_FLAG_ROBUST)
        _lib.rtcSetSceneBuildQuality(self.handle, QUALITY[mesh.quality])
        geom = _lib.rtcNewGeometry(mesh._device, _RTC_GEOMETRY_TYPE_TRIANGLE)
        if not geom:
            raise RuntimeError("Embree could not make a triangle geometry")
        _lib.rtcSetSharedGeometryBuffer(geom, _RTC_BUFFER_TYPE_VERTEX, 0, _RTC_FORMAT_FLOAT3,
                                        mesh._vbuf.ctypes.data, 0, 12, len(mesh.vertices))
        _lib.rtcSetSharedGeometryBuffer(geom, _RTC_BUFFER_TYPE_INDEX, 0, _RTC_FORMAT_UINT3,
                                        mesh._faces.ctypes.data, 12 * start, 12, stop - start)
        _lib.rtcSetGeometryBuildQuality(geom, QUALITY[mesh.quality])
        _lib.rtcCommitGeometry(geom)
        _lib.rtcAttachGeometryByID(self.handle, geom, geom_id)
        _lib.rtcReleaseGeometry(geom)
        _lib.rtcCommitScene(self.handle)

    def __del__(self):
        if _lib is not None and getattr(self, "handle", None):
            _lib.rtcReleaseScene(self.handle)


def instance(scene, handles, offsets=None) -> None:
    """Put each Embree scene (a raw handle: a ``Group``'s, or an embreex scene's from
    ``handle_of``) into an empty embreex scene as an instance, moved by its row of ``offsets``
    (none: in place). Embree keeps each instanced scene alive while an instance holds it."""
    handle = _handle(scene)
    device = _lib.rtcGetSceneDevice(handle)
    for i, inner in enumerate(handles):
        geom = _lib.rtcNewGeometry(device, _RTC_GEOMETRY_TYPE_INSTANCE)
        if not geom:
            raise RuntimeError("Embree could not make an instance")
        _lib.rtcSetGeometryInstancedScene(geom, inner)
        transform = _IDENTITY.copy()
        if offsets is not None:
            transform[9:] = offsets[i]
        _lib.rtcSetGeometryTransform(geom, 0, _RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, transform.ctypes.data)
        _lib.rtcCommitGeometry(geom)
        _lib.rtcAttachGeometry(handle, geom)
        _lib.rtcReleaseGeometry(geom)
    scene.is_committed = 0


def handle_of(scene):
    """The RTCScene handle of an embreex scene, for ``instance``."""
    return _handle(scene)


def _handle(scene):
    return ctypes.c_void_p.from_address(id(scene) + _scene_offset).value


def available(new_scene) -> bool:
    """Whether direct geometry works in this process; ``new_scene()`` makes an empty embreex
    EmbreeScene. Checked once: a ray must hit an attached triangle, miss beside it, and hit
    there once the triangle is moved larger; through an instance of a group of that one
    triangle it must name the group's geometry and the triangle's place in the group."""
    global _lib, _scene_offset, _state
    if _state != "unchecked":
        return _state == "on"
    _state = "off"
    try:
        _lib = _load_library()
        scene = new_scene()
        _scene_offset = _find_scene_offset(scene) if _lib is not None else None
        if _scene_offset is None:
            return False
        tri = Triangles(scene, np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [5, 5, 5]], float),
                        np.array([[3, 3, 3], [0, 1, 2]]))

        def first_hit(target, x):
            o = np.array([[x, x, 1.0]], np.float32)
            r = target.run(o, np.array([[0, 0, -1.0]], np.float32), output=1)
            return int(r["geomID"][0]), int(r["primID"][0])

        before = first_hit(scene, 0.25)[1], first_hit(scene, 0.75)[1]
        tri.move(np.array([[0, 0, 0], [2, 0, 0], [0, 2, 0], [5, 5, 5]], float))
        group, top = Group(tri, 1, 2, geom_id=7), new_scene()
        instance(top, [group.handle])
        if before == (1, -1) and first_hit(scene, 0.75)[1] == 1 and first_hit(top, 0.75) == (7, 0):
            _state = "on"
    except (OSError, AttributeError, ValueError, RuntimeError, TypeError):
        _state = "off"
    return _state == "on"
