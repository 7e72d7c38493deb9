"""What users run in Blender: thin bpy operators over the services in addon/ (each reads the scene
once, calls core, writes once; ``base`` has what they share)."""
