"""Layered ray tracing for display (thesis ch. 2 and 4): camera rays that skip what a higher layer
covers, and Whitted shading."""
