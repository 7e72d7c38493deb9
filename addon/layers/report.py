"""What the last resolve, Inspect or frame-by-frame correction found, kept on the scene for the
panel, the command line and the next run (the per-part probe distances the resolve used): one
typed record, written by every writer and read by every reader."""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field, fields


@dataclass
class LayersReport:
    kind: str  # "resolve", "inspect" or "stopped" (Resolve on Frame Change gave up)
    message: str
    # a resolve's
    seconds: dict = field(default_factory=dict)  # read, resolve, write, total
    garments: list = field(default_factory=list)  # names, inner to outer
    max_move: list = field(default_factory=list)  # per garment, scene units
    faces_hidden: list = field(default_factory=list)  # per garment, polygons
    parts: str = ""  # where the body parts came from
    skirts: list = field(default_factory=list)  # garment names
    far_from_body: int = 0  # garment points farther from the body than the probe reaches
    inward: list = field(default_factory=list)  # garments whose faces mostly face the body
    probe_by_part: dict = field(default_factory=dict)  # l_s the resolve used per part, scene units
    stages_s: dict = field(default_factory=dict)
    # Inspect's
    crossings_before: int = 0
    crossings_after: int = 0
    still_crossing: list = field(default_factory=list)  # [name, name, crossing edges]
    poke_through_before: float = 0.0
    poke_through_after: float = 0.0
    max_move_m: float = 0.0
    max_stretch: float = 1.0
    stale: list = field(default_factory=list)  # [garment, why]


def write(scene, report: LayersReport | None) -> None:
    """Keep ``report`` on the scene (None clears it)."""
    scene.deformrt.last_report = "" if report is None else json.dumps(asdict(report))


def read(scene) -> LayersReport | None:
    """The scene's last report, or None (none yet, or one this version cannot read)."""
    return from_json(scene.deformrt.last_report)


# A report this version writes is a few kilobytes; a file may hold anything (a 64 MB string froze
# the panel's redraw for minutes, a 200,000-deep list overflowed the parser on every redraw)
MAX_CHARS = 64 * 1024
DAMAGED = LayersReport(kind="damaged", message="The last report stored in this file cannot be read (damaged); "
                       "Resolve Layers or Inspect writes a new one")


def from_json(text: str) -> LayersReport | None:
    """The report in ``text``; None for none (or one from a version without reports), DAMAGED for
    one that is too long, not JSON, nested past reason or with a field of the wrong type."""
    if not text:
        return None
    if not isinstance(text, str) or len(text) > MAX_CHARS:
        return DAMAGED
    try:
        data = json.loads(text)
    except (ValueError, RecursionError):
        return DAMAGED
    if not isinstance(data, dict) or "message" not in data:
        return None
    values = {"kind": data.get("kind", ""), **{f.name: data[f.name] for f in fields(LayersReport) if f.name in data}}
    defaults = LayersReport(kind="", message="")
    for name, value in values.items():
        want = type(getattr(defaults, name))
        if not (isinstance(value, want) or (want is float and isinstance(value, int))) or isinstance(value, bool) \
                and want is not bool:
            return DAMAGED
    return LayersReport(**values)
