"""What resolve_layers returns."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass


@dataclass
class FoundOnBody:
    """Per garment what the body search found: whether it came near another garment
    (``traced``), its global normals, BodyCorrespondence, segment per vertex, and the skirts;
    ``complete`` (or None) fills the untraced garments' entries in these lists in place."""

    traced: list
    normals: list
    correspondence: list
    segments: list
    skirts: list
    complete: Callable | None = None


def _found_on_first_use(name, doc):
    """A LayeringResult attribute whose untraced garments' entries are found when first read."""
    def get(self):
        self._completed()
        return getattr(self._found, name)
    return property(get, doc=doc)


class LayeringResult:
    """What resolve_layers returns. ``garments``: corrected trimesh.Trimesh per garment, hidden
    faces left out; ``moved``: (n_i, 3) displacement per garment vertex; ``removed_faces``:
    (m_i,) bool per input face; ``traced``: per garment, whether it came near another garment
    (the rest cannot move or lose a face and skip every stage); ``stats``: counts and seconds.

    ``global_normals`` (the n' per garment vertex), ``correspondence`` (BodyCorrespondence per
    garment, rest pose) and ``segments`` (segment id per vertex) of garments whose box was far
    from every other garment's are found on first use: the body search they need is most of a
    resolve's time."""

    def __init__(self, garments, moved, removed_faces, stats, found: FoundOnBody):
        self.garments, self.moved, self.removed_faces, self.traced = garments, moved, removed_faces, found.traced
        self.stats = stats
        self._found = found
        self.frames_clear = None  # per garment and face, frames since it last crossed (resolve's hold)
        self.frames_shown = None  # per garment and face, frames it has been shown (capped at 2)
        self.body_radius = None  # the body's radii the probes took, for the next frame
        self.body_junctions = None  # where the body's parts meet (BodyFacts.junctions_found), the same
        self.lifts = None  # per garment, how far each vertex was lifted off the body (body_lift)
        self.history = None  # frame_coherence.History: what the next frame eases from

    def _completed(self):
        if self._found.complete is not None:
            self._found.complete()
            self._found.complete = None

    global_normals = _found_on_first_use("normals", "(n_i, 3) the n' used per garment vertex")
    correspondence = _found_on_first_use("correspondence", "BodyCorrespondence per garment (rest pose)")
    segments = _found_on_first_use("segments", "(n_i,) segment id per garment vertex")

    @property
    def skirts(self) -> list:
        """Which garments are skirts (their hem goes round both legs), sorted; stats["skirts"]
        names those the resolve searched the body for."""
        self._completed()
        return sorted(self._found.skirts)

    def found(self) -> tuple[list, list]:
        """(global normals, correspondence) per garment as the resolve found them, with None for
        the garments whose body points it did not search, without searching for those: what a
        caller that reads the others (or passes the correspondence back next frame) needs."""
        return list(self._found.normals), list(self._found.correspondence)
