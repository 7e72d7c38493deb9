"""The sidebar panels drawn into a recording layout (background Blender draws none): what a user
sees, in which order, and that no line is wider than the sidebar."""

import importlib
import json
import re

import bpy
import pytest


class Recorder:
    """A UILayout stand-in: every row, column and box is the same flat list of what was drawn."""

    def __init__(self, drawn=None):
        self.drawn = [] if drawn is None else drawn

    def __getattr__(self, name):
        if name in ("row", "column", "box", "split"):
            return lambda *a, **k: Recorder(self.drawn)
        if name == "operator":
            def operator(idname, text=None, **k):
                self.drawn.append(("op", idname, text))
                return type("Props", (), {})()
            return operator
        if name in ("label", "prop", "separator"):
            def record(*a, **k):
                self.drawn.append((name, k.get("text", a[1] if len(a) > 1 else None)))
            return record
        raise AttributeError(name)

    def __setattr__(self, name, value):
        object.__setattr__(self, name, value)


def draw(extension, panel_name):
    panels = importlib.import_module(f"{extension.__name__}.addon.ui.panels")
    panel = getattr(panels, panel_name)
    layout = Recorder()
    panel.draw(type("Panel", (), {"layout": layout})(), bpy.context)
    return layout.drawn


@pytest.fixture
def tubes(extension, clean_scene):
    return importlib.import_module(f"{extension.__name__}.sample_scenes.tubes").build(seed=0, resolution=32)


def test_the_resolve_panel_puts_everyday_work_first_and_clearing_last(extension, tubes):
    ops = [(d[1], d[2]) for d in draw(extension, "DEFORMRT_PT_resolve") if d[0] == "op"]
    names = [o for o, _ in ops]
    assert names.index("deformrt.resolve_layers") + 1 == names.index("deformrt.inspect_layers")
    assert names[-1] == "deformrt.clear_results"  # destructive: last, apart
    assert names.index("deformrt.bake_frames") > names.index("deformrt.inspect_layers")
    assert all(text != "" for _, text in ops)  # every button says what it does


def test_a_long_report_is_wrapped_to_the_sidebar(extension, tubes):
    assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
    message = json.loads(bpy.context.scene.deformrt.last_report)["message"]
    assert len(message) > 60
    labels = [d[1] for d in draw(extension, "DEFORMRT_PT_resolve") if d[0] == "label" and d[1]]
    assert all(len(t) <= 60 for t in labels)  # no region in background: 60 characters
    assert " ".join(labels).replace("  ", " ").find(message[:40]) >= 0


def test_the_jellyfish_has_a_tab_of_its_own(extension):
    panels = importlib.import_module(f"{extension.__name__}.addon.ui.panels")
    assert panels.DEFORMRT_PT_jellyfish.bl_category != panels.DEFORMRT_PT_layers.bl_category


def test_a_damaged_or_crafted_report_is_named_and_the_panel_still_draws(extension, tubes):
    """A 64 MB message, a 200,000-deep list, a field of the wrong type, entries of the wrong shape:
    each draws the one sentence saying the report is damaged (a few labels, not a label per 60
    characters of 64 MB) and never raises."""
    scene = bpy.context.scene
    damaged = importlib.import_module(f"{extension.__name__}.addon.layers.report").DAMAGED.message
    good = json.dumps({"kind": "resolve", "message": "Resolved 2 garments"})
    for text in ('{"message": "' + "x" * (64 << 20) + '"}', "[" * 200_000 + "]" * 200_000,
                 '{"message": 5}', '{"message": "m", "still_crossing": [["a", "b"]]}',
                 '{"message": "m", "probe_by_part": {"torso": "wide"}}', "not json"):
        scene.deformrt.last_report = text
        labels = [d[1] for d in draw(extension, "DEFORMRT_PT_resolve") if d[0] == "label" and d[1]]
        assert len(labels) <= 6
        assert damaged[:40] in " ".join(labels).replace("  ", " "), text[:40]
    scene.deformrt.last_report = good
    labels = [d[1] for d in draw(extension, "DEFORMRT_PT_resolve") if d[0] == "label" and d[1]]
    assert "Resolved 2 garments" in labels and damaged[:40] not in " ".join(labels)


# words that belong to the method's papers and the code, not to an artist's screen: the dissertation,
# its probe rays, stored attribute names and enum identifiers
RESEARCH_WORDS = re.compile(r"thesis|dissertation|\bthe seed\b|probe ray|\bdeformrt_[a-z]\w*|\bga-sa\b|\bS5\b|\bS13\b"
                            r"|\bfitness\b", re.IGNORECASE)


def _rna_texts(cls):
    """What Blender shows of a registered class: its label and tooltip, each property's name and
    tooltip, each enum item's name and tooltip."""
    rna = cls.bl_rna
    out = [rna.description, getattr(cls, "bl_label", ""), getattr(cls, "bl_description", "")]
    for prop in rna.properties:
        if prop.identifier in ("rna_type", "bl_idname", "bl_label", "bl_description", "bl_options",
                               "bl_space_type", "bl_region_type", "bl_category", "bl_context"):
            continue
        out += [prop.name, prop.description]
        if prop.type == "ENUM":
            out += [t for item in prop.enum_items for t in (item.name, item.description)]
    return out


def test_no_research_words_reach_the_screen(extension, tubes):
    """Every label, tooltip, enum entry, panel line and report an artist sees is in their words:
    none names the dissertation, its probe rays, a stored attribute, a raw enum identifier or
    the search's fitness (checked on everything the add-on registers, the panels drawn over a
    resolved and an inspected scene, and a jellyfish with an optimised stroke)."""
    mods = {m: importlib.import_module(f"{extension.__name__}.{m}") for m in (
        "addon.properties", "addon.ui.preferences", "addon.ui.panels", "operators.tagging", "operators.layering",
        "operators.jellyfish", "addon.render.engine", "addon.jellyfish.animal")}
    classes = [c for m in mods.values() for c in getattr(m, "CLASSES", ())]
    classes += [mods["addon.render.engine"].DEFORMRT_RE_layered, mods["addon.render.engine"].DEFORMRT_PT_layered_render]
    texts = [t for c in classes for t in _rna_texts(c)]
    assert bpy.ops.deformrt.resolve_layers() == {"FINISHED"}
    assert bpy.ops.deformrt.inspect_layers() == {"FINISHED"}
    for panel in ("DEFORMRT_PT_layers", "DEFORMRT_PT_resolve"):
        texts += [d[-1] or "" for d in draw(extension, panel)]
    texts.append(json.loads(bpy.context.scene.deformrt.last_report)["message"])
    assert bpy.ops.deformrt.add_jellyfish() == {"FINISHED"}
    bell = mods["addon.jellyfish.animal"].jellyfish_of(bpy.context.active_object)
    bell[mods["addon.jellyfish.animal"].PROP_STROKE] = json.dumps(
        {"method": "ga-sa", "fitness": 0.1, "evaluations": 8, "diameters_per_cycle": 0.02, "energy_share": 0.9})
    texts += [d[-1] or "" for d in draw(extension, "DEFORMRT_PT_jellyfish")]
    assert len(texts) > 150  # the check saw the add-on's screens, not an empty list
    found = sorted({t for t in texts if t and RESEARCH_WORDS.search(t)})
    assert not found, found
    # and in Blender's own spelling (Optimize, Normalize): none says "optimise"
    assert not [t for t in texts if t and "optimis" in t.lower()]
