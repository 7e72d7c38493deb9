"""Shared geometry: vectors and boxes, mesh topology, vertex normals, the volume spline (RBF),
content keys, and the thread pool that splits array work across cores."""
