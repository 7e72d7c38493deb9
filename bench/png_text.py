"""Labels on the benches' plots without a plotting package: a 3 x 5 pixel font for the few
characters the plots use (digits, axis units, case names), drawn at a whole-number scale."""

import numpy as np

_GLYPHS = {
    "0": "111101101101111", "1": "010110010010111", "2": "111001111100111", "3": "111001111001111",
    "4": "101101111001001", "5": "111100111001111", "6": "111100111101111", "7": "111001001001001",
    "8": "111101111101111", "9": "111101111001111", "x": "000101010101000", "m": "000110111101101",
    "s": "000011110011110", "f": "011100110100100", "r": "000101110100100", "a": "000011101101011",
    "e": "010101111100011", " ": "000000000000000", ".": "000000000000010", "-": "000000111000000",
    "/": "001001010100100", "h": "100100111101101", "t": "010111010010011",
}


def text_width(text: str, scale: int = 2) -> int:
    return 4 * scale * len(text) - scale


def draw_text(img, x: int, y: int, text: str, colour=(0, 0, 0), scale: int = 2) -> None:
    """Write ``text`` with its top-left corner at pixel (x, y) of an (h, w, 3) image; characters
    outside the font raise, so a label never silently goes missing."""
    h, w, _ = img.shape
    for i, ch in enumerate(text):
        if ch not in _GLYPHS:
            raise ValueError(f"no glyph for {ch!r}: the plot font has {''.join(sorted(_GLYPHS))}")
        bits = np.array([int(b) for b in _GLYPHS[ch]], dtype=bool).reshape(5, 3)
        block = np.kron(bits, np.ones((scale, scale), dtype=bool))
        x0 = x + 4 * scale * i
        ys, xs = np.nonzero(block)
        ys, xs = ys + y, xs + x0
        keep = (ys >= 0) & (ys < h) & (xs >= 0) & (xs < w)
        img[ys[keep], xs[keep]] = colour
