"""Artificial jellyfish (thesis ch. 3): the 2D bell and its RBF space mapping, the particle-gridless
fluid around it, swimming cycles and their fitness, the stroke search, the 3D bell and tentacles."""

from .swimming import (
    CycleResult,
    FitnessScales,
    JellyfishConfig,
    OptimizeResult,
    StrokeSpace,
    default_config,
    default_creature,
    fitness,
    one_cycle,
    optimize,
    reference_scales,
    simulate_cycle,
    simulate_cycles,
)

__all__ = ["CycleResult", "FitnessScales", "JellyfishConfig", "OptimizeResult", "StrokeSpace", "default_config",
           "default_creature", "fitness", "one_cycle", "optimize", "reference_scales", "simulate_cycle",
           "simulate_cycles"]
