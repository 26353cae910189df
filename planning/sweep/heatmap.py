"""The success heat map of a sweep over two axes, as a PNG written with zlib and struct (no plotting library).

Each cell is colored from red (0 %) through yellow to green (100 %) by its success rate, gray when nothing ran,
and shows successes/runs; the axes' names and values are written in a small built-in bitmap font (3×5, drawn 2×).
"""

from __future__ import annotations

import struct
import zlib
from typing import Any

import numpy as np

# 3×5 glyphs: five rows of three bits (the leftmost bit is 4).
_FONT: dict[str, tuple[int, ...]] = {
    "0": (7, 5, 5, 5, 7), "1": (2, 6, 2, 2, 7), "2": (7, 1, 7, 4, 7), "3": (7, 1, 7, 1, 7), "4": (5, 5, 7, 1, 1),
    "5": (7, 4, 7, 1, 7), "6": (7, 4, 7, 5, 7), "7": (7, 1, 1, 2, 2), "8": (7, 5, 7, 5, 7), "9": (7, 5, 7, 1, 7),
    "A": (2, 5, 7, 5, 5), "B": (6, 5, 6, 5, 6), "C": (3, 4, 4, 4, 3), "D": (6, 5, 5, 5, 6), "E": (7, 4, 6, 4, 7),
    "F": (7, 4, 6, 4, 4), "G": (3, 4, 5, 5, 3), "H": (5, 5, 7, 5, 5), "I": (7, 2, 2, 2, 7), "J": (1, 1, 1, 5, 2),
    "K": (5, 5, 6, 5, 5), "L": (4, 4, 4, 4, 7), "M": (5, 7, 7, 5, 5), "N": (6, 5, 5, 5, 5), "O": (2, 5, 5, 5, 2),
    "P": (6, 5, 6, 4, 4), "Q": (2, 5, 5, 6, 3), "R": (6, 5, 6, 5, 5), "S": (3, 4, 2, 1, 6), "T": (7, 2, 2, 2, 2),
    "U": (5, 5, 5, 5, 7), "V": (5, 5, 5, 5, 2), "W": (5, 5, 7, 7, 5), "X": (5, 5, 2, 5, 5), "Y": (5, 5, 2, 2, 2),
    "Z": (7, 1, 2, 4, 7), ".": (0, 0, 0, 0, 2), "-": (0, 0, 7, 0, 0), "+": (0, 2, 7, 2, 0), "/": (1, 1, 2, 4, 4),
    "%": (5, 1, 2, 4, 5), "_": (0, 0, 0, 0, 7), ":": (0, 2, 0, 2, 0), ",": (0, 0, 0, 2, 4), "[": (6, 4, 4, 4, 6),
    "]": (3, 1, 1, 1, 3), "(": (2, 4, 4, 4, 2), ")": (2, 1, 1, 1, 2), "=": (0, 7, 0, 7, 0), " ": (0, 0, 0, 0, 0),
    "?": (7, 1, 2, 0, 2),
}  # fmt: skip
_SCALE = 2
_ADV = 4 * _SCALE  # pixels per character
_LINE = 7 * _SCALE  # pixels per line


def _text(img: np.ndarray, x: int, y: int, s: str, color: tuple[int, int, int] = (20, 20, 20)) -> None:
    s = s.upper().replace("–", "-").replace("×", "X")
    h, w, _ = img.shape
    for ch in s:
        rows = _FONT.get(ch, _FONT["?"])
        for r, bits in enumerate(rows):
            for c in range(3):
                if bits & (4 >> c):
                    y0, x0 = y + r * _SCALE, x + c * _SCALE
                    if 0 <= y0 and y0 + _SCALE <= h and 0 <= x0 and x0 + _SCALE <= w:
                        img[y0 : y0 + _SCALE, x0 : x0 + _SCALE] = color
        x += _ADV


def rate_color(rate: float | None) -> tuple[int, int, int]:
    """Red at 0, yellow at 0.5, green at 1; gray for None."""
    if rate is None:
        return (200, 200, 200)
    r = min(max(rate, 0.0), 1.0)
    if r < 0.5:
        return (220, int(60 + 2 * r * 160), 60)
    return (int(220 - 2 * (r - 0.5) * 170), 220 - int(2 * (r - 0.5) * 40), 60)


def render(heatmap: dict[str, Any], title: str = "") -> np.ndarray:
    """The heat map of summary()["heatmap"] as an RGB image (H, W, 3) of uint8."""
    xs, ys = heatmap["x_labels"], heatmap["y_labels"]
    ok, done = heatmap["successes"], heatmap["done"]
    longest = max([len(f"{k}/{n}") for row_k, row_n in zip(ok, done, strict=True) for k, n in zip(row_k, row_n, strict=True)] + [len(x) for x in xs] + [3])  # fmt: skip
    cw = max(44, longest * _ADV + 8)
    ch = 30
    left = max(len(y) for y in ys) * _ADV + 16
    top = 3 * _LINE + 8
    bottom = 2 * _LINE + 8
    width = max(left + cw * len(xs) + 12, len(title) * _ADV + 16, (len(heatmap["x"]) + 4) * _ADV + left)
    height = top + ch * len(ys) + bottom
    img = np.full((height, width, 3), 255, dtype=np.uint8)
    _text(img, 8, 6, title)
    _text(img, 8, 6 + _LINE, f"y: {heatmap['y']}")
    for j, y in enumerate(reversed(ys)):  # the first value at the bottom
        row = len(ys) - 1 - j
        y0 = top + j * ch
        _text(img, 8, y0 + ch // 2 - 5, y)
        for i in range(len(xs)):
            x0 = left + i * cw
            k, n = ok[row][i], done[row][i]
            img[y0 + 1 : y0 + ch - 1, x0 + 1 : x0 + cw - 1] = rate_color(k / n if n else None)
            label = f"{k}/{n}" if n else "-"
            _text(img, x0 + (cw - len(label) * _ADV) // 2 + 1, y0 + ch // 2 - 5, label)
    y_axis = top + ch * len(ys) + 4
    for i, x in enumerate(xs):
        _text(img, left + i * cw + (cw - len(x) * _ADV) // 2 + 1, y_axis, x)
    _text(img, left, y_axis + _LINE, f"x: {heatmap['x']}")
    return img


def png_bytes(img: np.ndarray) -> bytes:
    """An RGB uint8 image (H, W, 3) as PNG bytes."""
    h, w, _ = img.shape
    raw = b"".join(b"\x00" + img[r].tobytes() for r in range(h))  # filter type 0 on every row

    def chunk(kind: bytes, data: bytes) -> bytes:
        return (
            struct.pack(">I", len(data))
            + kind
            + data
            + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)
        )

    ihdr = struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0)
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", ihdr)
        + chunk(b"IDAT", zlib.compress(raw, 6))
        + chunk(b"IEND", b"")
    )


def write_png(path: Any, heatmap: dict[str, Any], title: str = "") -> None:
    """Writes the heat map as a PNG file."""
    from pathlib import Path

    Path(path).write_bytes(png_bytes(render(heatmap, title)))
