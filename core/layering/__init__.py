"""Layered garments (thesis ch. 4): lower layers moved behind higher ones, what still shows
through hidden, and what a resolve needs of the body and the garments."""

from .correspondence import BodyCorrespondence
from .resolve import LayeringResult, resolve_layers

__all__ = ["BodyCorrespondence", "LayeringResult", "resolve_layers"]
