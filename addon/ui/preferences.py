"""Extension preferences."""

import os

import bpy
from bpy.props import IntProperty

# The extension's root package ("bl_ext.<repo>.deformrt", or "deformrt" when run from a checkout).
ROOT_PACKAGE = __package__.rsplit(".", 2)[0]


def apply_thread_setting(_self=None, _context=None):
    prefs = get()
    threads = prefs.threads if prefs is not None else 0
    if threads > 0:
        os.environ["DEFORMRT_THREADS"] = str(threads)
    else:
        os.environ.pop("DEFORMRT_THREADS", None)


class DEFORMRT_AP_preferences(bpy.types.AddonPreferences):
    bl_idname = ROOT_PACKAGE

    threads: IntProperty(
        name="Ray Threads",
        description="Threads for ray tracing; 0 uses every core",
        default=0,
        min=0,
        max=256,
        update=apply_thread_setting,
    )

    def draw(self, _context):
        self.layout.prop(self, "threads")


def get():
    addon = bpy.context.preferences.addons.get(ROOT_PACKAGE)
    return addon.preferences if addon is not None else None


CLASSES = (DEFORMRT_AP_preferences,)
