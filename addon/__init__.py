"""The Blender side's parts under the operators: moving mesh data between Blender and numpy (io),
the layering service and its non-destructive result (layers), the jellyfish in the scene
(jellyfish), the DeformRT Layered render engine (render), the sidebar and preferences (ui), and
the properties they keep on scenes and objects. Registered from the package root."""
