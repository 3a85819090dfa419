# SPDX-License-Identifier: GPL-3.0-or-later
"""Input files for the command-line and Blender tests, written without bpy: an OBJ grid, PNG samples."""
import struct

import numpy as np

def write_grid_obj(path, cells=4, size=2.0):
    """A size x size grid of cells x cells quads in the xy plane with planar UVs (u, v) = (x, y) / size + .5."""
    lines, n = [], cells + 1
    for j in range(n):
        for i in range(n):
            x, y = (i / cells - 0.5) * size, (j / cells - 0.5) * size
            lines.append("v %g %g 0" % (x, y))
            lines.append("vt %g %g" % (i / cells, j / cells))
    for j in range(cells):
        for i in range(cells):
            a = j * n + i + 1
            corners = (a, a + 1, a + n + 1, a + n)
            lines.append("f " + " ".join("%d/%d" % (c, c) for c in corners))
    path.write_text("\n".join(lines) + "\n")
    return path


def png_size(path):
    with open(path, "rb") as handle:
        header = handle.read(24)
    assert header[:8] == b"\x89PNG\r\n\x1a\n", header[:8]
    return struct.unpack(">II", header[16:24])


def write_png(path, pixels):
    """An 8-bit RGB PNG of (H, W, 3) uint8 pixels (row 0 = top), written with zlib (no bpy here)."""
    import struct
    import zlib
    raw = b"".join(b"\x00" + row.tobytes() for row in pixels)

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xffffffff)
    height, width = pixels.shape[:2]
    with open(path, "wb") as handle:
        handle.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
                     + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))
    return str(path)


def pebbles_png(path, flat=False):
    """Ground with 4 stones and 2 leaves (or the ground alone)."""
    pixels = np.zeros((64, 96, 3), np.uint8)
    pixels[:] = (51, 77, 64)
    if not flat:
        for x0, y0 in [(8, 8), (40, 8), (70, 30), (20, 40)]:
            pixels[y0:y0 + 10, x0:x0 + 10] = (230, 51, 25)
        for x0, y0 in [(55, 6), (82, 40)]:
            pixels[y0:y0 + 14, x0:x0 + 6] = (25, 153, 25)
    return write_png(path, pixels)
