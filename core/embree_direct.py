"""Triangle geometry handed to Embree without copying, and moved in place.

embreex builds a mesh by copying it vertex by vertex through Python-level array indexing:
about 0.9 us per triangle, five times what Embree's own BVH build then takes, and it has no
way to move a mesh. Here the same Embree library that embreex loaded is called through
ctypes: the geometry shares numpy buffers (rtcSetSharedGeometryBuffer), and a deforming mesh
is written in place and committed again instead of being made anew. Tracing stays with
embreex, on the very scene embreex made.

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
_RTC_BUFFER_TYPE_INDEX = 0
_RTC_BUFFER_TYPE_VERTEX = 1
_RTC_FORMAT_UINT3 = 0x5003
_RTC_FORMAT_FLOAT3 = 0x9003

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
    builds the BVH again on the next ray: its REFIT quality measured no faster here)."""

    def __init__(self, scene, vertices, faces):
        handle = ctypes.c_void_p.from_address(id(scene) + _scene_offset).value
        device = _lib.rtcGetSceneDevice(handle)
        self._scene = scene
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
        _lib.rtcCommitGeometry(geom)
        _lib.rtcAttachGeometry(handle, geom)
        self._geom = geom  # the scene holds the reference from here on
        _lib.rtcReleaseGeometry(geom)

    def move(self, vertices) -> None:
        self.vertices[:] = vertices
        _lib.rtcUpdateGeometryBuffer(self._geom, _RTC_BUFFER_TYPE_VERTEX, 0)
        _lib.rtcCommitGeometry(self._geom)
        self._scene.is_committed = 0  # embreex commits the scene again before the next ray


def available(new_scene) -> bool:
    """Whether direct geometry works in this process; ``new_scene()`` makes an empty embreex
    EmbreeScene. Checked once: a ray must hit an attached triangle, miss beside it, and hit
    there once the triangle is moved larger."""
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

        def first_face(x):
            o = np.array([[x, x, 1.0]], np.float32)
            return int(scene.run(o, np.array([[0, 0, -1.0]], np.float32), output=1)["primID"][0])

        before = first_face(0.25), first_face(0.75)
        tri.move(np.array([[0, 0, 0], [2, 0, 0], [0, 2, 0], [5, 5, 5]], float))
        if before == (1, -1) and first_face(0.75) == 1:
            _state = "on"
    except (OSError, AttributeError, ValueError, RuntimeError, TypeError):
        _state = "off"
    return _state == "on"
