"""Artificial jellyfish (thesis ch. 3): the 2D bell and its RBF space mapping, the particle-gridless
fluid around it, swimming cycles and their fitness, the stroke search, the 3D bell and tentacles."""

from .fitness import FitnessScales, fitness
from .stroke_search import GOAL_WEIGHTS, OptimizeResult, Running, Search, StrokeSpace, optimize, reference_scales
from .swimming import (
    CycleResult,
    JellyfishConfig,
    default_config,
    default_creature,
    one_cycle,
    simulate_cycle,
    simulate_cycles,
)
from .waters import WATERS

__all__ = ["GOAL_WEIGHTS", "WATERS", "CycleResult", "FitnessScales", "JellyfishConfig", "OptimizeResult", "Running",
           "Search", "StrokeSpace", "default_config", "default_creature", "fitness", "one_cycle", "optimize",
           "reference_scales", "simulate_cycle", "simulate_cycles"]
