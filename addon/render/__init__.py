"""The DeformRT Layered render engine: reading the render's depsgraph into ray scenes, then
tracing and shading in core.render."""
