"""Mesh data between Blender and numpy (foreach_get/foreach_set only), and the API differences
between the Blender versions DeformRT runs in."""
