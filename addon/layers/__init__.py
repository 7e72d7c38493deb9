"""The layering service: which objects take part, read once - resolve in core - write once, the
non-destructive result (a Geometry Nodes modifier and its data), where it sits in the stack,
noticing when it no longer fits, and resolving frame by frame."""
