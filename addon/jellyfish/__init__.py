"""The jellyfish in the scene: building the 3D bell, storing the optimised stroke on it, baking
its swimming to shape keys and keyframes."""
