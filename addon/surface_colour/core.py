# SPDX-License-Identifier: GPL-3.0-or-later
"""bpy-free part the surface-colour methods share: colour spaces of the output, the target's texel density
and the working sample reduced to it, the image target, and vertex samples (round.py and patches.py hold
each method's caches and native call).

Round neighbourhoods (Chen & Dong 2008) and vector-field patches (Chen, Liu & Dong) synthesize values as
the sample stores them; the bpy layer decides the output's colour space (an sRGB byte image keeps them, a
float image or a colour attribute gets linear values).
"""
import dataclasses

import numpy as np

from ..core.sample_image import srgb_to_linear

COLOUR_ATTRIBUTE_NAME = "TexSynth_Colour"  # VERTICES target: FLOAT_COLOR point attribute
IMAGE_PREFIXES = {"ROUND": "TexSynth Round: ", "PATCHES": "TexSynth Patches: "}  # default IMAGE target names
MAX_OVERLAP_FRACTION = 0.01  # as round_synth.hpp: a few folded texels are accepted, overlapping islands not


def linear_to_srgb(values):
    values = np.clip(np.asarray(values, dtype=np.float64), 0.0, None)
    return np.where(values <= 0.0031308, values * 12.92, 1.055 * np.power(values, 1.0 / 2.4) - 0.055)


def output_values(colour, sample_srgb, output_linear):
    """Synthesized RGB(A) values converted from the sample's encoding to the output's; alpha untouched."""
    colour = np.asarray(colour, dtype=np.float32)
    if bool(sample_srgb) == (not output_linear):
        return colour
    convert = srgb_to_linear if sample_srgb else linear_to_srgb
    out = colour.copy()
    channels = min(3, colour.shape[-1])
    out[..., :channels] = convert(colour[..., :channels]).astype(np.float32)
    return out


def target_density(positions, triangles, corner_uvs, target):
    """Surface samples per world unit along a line: image target, sqrt(texels covered / surface area)
    from the UV and 3D areas; vertex target, 1 / mean edge length. 0 when unknown (degenerate)."""
    corners = np.asarray(positions, dtype=np.float64)[np.asarray(triangles)]
    if corners.size == 0:
        return 0.0
    if target.kind == "IMAGE":
        area = 0.5 * np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1).sum()
        uv = np.asarray(corner_uvs, dtype=np.float64) * np.array([target.width, target.height], np.float64)
        e1, e2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
        texels = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum()
        return float(np.sqrt(texels / area)) if area > 0.0 and texels > 0.0 else 0.0
    edges = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2)
    mean = float(edges.mean())
    return 1.0 / mean if mean > 0.0 else 0.0


def _area_average_rows(array, size_out, columns_per_chunk=256):
    """(size_out, W, C) float32: output row j = mean of the input rows over [j f, (j + 1) f), f = H / size_out.
    Pixels are constant over their unit interval, so the integral up to t is prefix[floor t] + frac(t) *
    row[floor t]: linear time, where dense (size_out x H) weights cost size_out x H x W x C (an 8K sample
    took over 10 minutes). Columns in chunks keep the float64 prefix sums to a few tens of MB."""
    height = array.shape[0]
    f = height / float(size_out)
    edges = np.arange(size_out + 1, dtype=np.float64) * f
    edges[-1] = height
    whole = np.minimum(np.floor(edges).astype(np.int64), height - 1)
    frac = (edges - whole)[:, None, None]
    out = np.empty((size_out,) + array.shape[1:], np.float32)
    for left in range(0, array.shape[1], columns_per_chunk):
        strip = np.asarray(array[:, left:left + columns_per_chunk], dtype=np.float64)
        prefix = np.zeros((height + 1,) + strip.shape[1:])
        np.cumsum(strip, axis=0, out=prefix[1:])
        integral = prefix[whole] + frac * strip[whole]
        out[:, left:left + columns_per_chunk] = (integral[1:] - integral[:-1]) / f
    return out


def smallest_sample_side(settings):
    """The native minimum: every level's K-ring neighbourhood fits in the sample (2K + 1 pixels of that
    level, 2^l finest pixels each), plus a pixel of slack for the crop to a multiple of 2^(levels - 1)."""
    levels = settings.round_levels
    return max((2 ** level) * (2 * (settings.round_coarse_rings if level == levels - 1 else settings.round_fine_rings)
                               + 1) for level in range(levels)) + 2 ** (levels - 1)


def working_sample(sample, texels_per_unit, density, resolution="AUTO", minimum=32):
    """(sample, texels_per_unit) to synthesize from. AUTO: when the target has fewer samples per unit
    than the sample has pixels (a minified texture), the sample is area-averaged down to the target's
    density, so each surface sample sees what a mipmap would show instead of single pixels picked
    from a sample it cannot resolve (broken mortar lines, aliasing). FULL: the sample as it is."""
    height, width = sample.shape[:2]
    ratio = texels_per_unit / density if density > 0.0 else 1.0
    if resolution != "AUTO" or ratio <= 1.05:
        return sample, texels_per_unit
    new_width = max(minimum, int(round(width / ratio)))
    new_height = max(minimum, int(round(height * new_width / float(width))))
    if new_width >= width:
        return sample, texels_per_unit
    rows = _area_average_rows(sample, new_height)
    reduced = _area_average_rows(rows.transpose(1, 0, 2), new_width).transpose(1, 0, 2)
    return np.ascontiguousarray(reduced), texels_per_unit * new_width / float(width)


@dataclasses.dataclass
class SurfaceTarget:
    """Where the colours go: IMAGE (width x height texels through corner_uvs, margin texels of bake
    margin) or VERTICES."""
    kind: str = "IMAGE"
    width: int = 0
    height: int = 0
    margin: int = 0


def vertex_samples(positions, triangles):
    """The VERTICES target's surface samples: each vertex used by a triangle, in the first triangle that
    has it (barycentrics of that corner), with area-weighted normals. Returns (vertex ids, positions,
    normals, triangle, barycentrics)."""
    positions = np.asarray(positions, dtype=np.float32)
    triangles = np.asarray(triangles, dtype=np.int32)
    corners = triangles.ravel()
    used, first = np.unique(corners, return_index=True)
    tri = (first // 3).astype(np.int32)
    corner = first % 3
    bary = np.zeros((used.size, 2), np.float32)
    bary[corner == 1, 0] = 1.0
    bary[corner == 2, 1] = 1.0
    p = positions.astype(np.float64)[triangles]
    face_normals = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    normals = np.zeros((positions.shape[0], 3), np.float64)
    for k in range(3):
        np.add.at(normals, triangles[:, k], face_normals)
    length = np.linalg.norm(normals, axis=1, keepdims=True)
    normals = np.where(length > 0, normals / np.maximum(length, 1e-300), [0.0, 0.0, 1.0])
    return used, positions[used], normals[used].astype(np.float32), tri, bary


                             # arrays copied again while the extra patches are appended


