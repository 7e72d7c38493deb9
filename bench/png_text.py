"""Labels on the benches' plots and the README's pictures without a plotting package: a 3 x 5 pixel
font (digits, lower-case letters, a little punctuation), drawn at a whole-number scale."""

import numpy as np

_GLYPHS = {
    "0": "111101101101111", "1": "010110010010111", "2": "111001111100111", "3": "111001111001111",
    "4": "101101111001001", "5": "111100111001111", "6": "111100111101111", "7": "111001001001001",
    "8": "111101111101111", "9": "111101111001111", "x": "000101010101000", "m": "000101111101101",
    "s": "000011110011110", "f": "011100110100100", "r": "000101110100100", "a": "000011101101011",
    "e": "010101111100011", " ": "000000000000000", ".": "000000000000010", "-": "000000111000000",
    "/": "001001010100100", "h": "100100111101101", "t": "010111010010011",
    "b": "100110101101110", "c": "000011100100011", "d": "001011101101011", "g": "011100101101011",
    "i": "010000010010010", "j": "001000001101010", "k": "100101110110101", "l": "110010010010111",
    "n": "000110101101101", "o": "000010101101010", "p": "000110101110100", "q": "000011101011001",
    "u": "000101101101011", "v": "000101101101010", "w": "000101101111101", "y": "000101011001110",
    "z": "000111001010111", "(": "010100100100010", ")": "010001001001010", ",": "000000000010100",
    ":": "000010000010000", "+": "000010111010000", "%": "101001010100101", "'": "010010000000000",
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
