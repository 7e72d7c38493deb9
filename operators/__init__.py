"""Thin bpy operators: each reads the scene once, calls core, writes once."""
