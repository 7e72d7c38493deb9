"""Every bundled scene by name: what builds it and what it holds (used by ``deformrt scenes``)."""

from . import dressed, makehuman, sea, sheets, tubes

SCENES = {
    "tubes": (lambda seed: tubes.build(seed=seed), "Capped-cylinder body, two noisy sleeves: the smallest case."),
    "fig_4_12": (lambda seed: dressed.fig_4_12(seed=seed),
                 "Thesis run (a), Fig. 4.12: wooden mannequin + jumpsuit + pants + two shirts, ~250k triangles."),
    "fig_4_13": (lambda seed: dressed.fig_4_13(seed=seed),
                 "Thesis run (b), Fig. 4.13: Skin-modifier figure + pants + shirt + two dresses, ~121k triangles."),
    "makehuman": (lambda seed: makehuman.build(seed=seed),
                  "A real outfit: MakeHuman's CC0 sports suit under its casual suit on its default female body, "
                  "each fitted alone; Subdivision 1/2 on every mesh."),
    "makehuman_animated": (lambda seed: makehuman.build_animated(seed=seed)[:2],
                           "The MakeHuman outfit on its default skeleton (Armature modifiers, MPFB2's weights): "
                           "96 frames from rest to MakeHuman's run and gym poses and back."),
    "posed": (lambda seed: dressed.posed(seed=seed),
              "Thesis run (c): wooden mannequin in T-shirt, pants and jacket; frame 1 rest, frame 2 posed."),
    "sheets": (lambda seed: sheets.build(layers=4, per_sheet=2048, seed=seed),
               "Thesis run (d), Table 4.1: four cloth sheets (2,048 triangles each) over two boxes and two spheres; "
               "cloth-cloth collision off. Other sizes: sheets.build(layers, per_sheet)."),
    "sea": (lambda seed: sea.build(), "Thesis run (e): sea water, sand floor and light for the jellyfish."),
}
# scenes whose cloth must run before the picture shows anything
SETTLE_FRAMES = {"sheets": 60}
GLB = {"fig_4_12", "fig_4_13", "posed"}
