# SPDX-License-Identifier: GPL-3.0-or-later
"""Test double of texsynth_native's preprocess/synthesize_jumpmap contract, used by the Blender tests
to exercise the add-on's I/O (bridge writes, atomicity, undo, UI) independently of the synthesizer.

It validates inputs like the real module and returns a planar projection with one-hot weights, so
the written layers can be checked against values computed here independently of the add-on.
"""
import types

import numpy as np


class CacheError(ValueError):
    pass


def _image_size(image):
    if isinstance(image, str):
        import bpy
        loaded = bpy.data.images.load(image, check_existing=True)
        width, height = loaded.size
        if width == 0:
            raise ValueError("cannot read image %s" % image)
        return int(width), int(height)
    array = np.asarray(image)
    return int(array.shape[1]), int(array.shape[0])


def preprocess(image, *, cache_dir=None, **params):
    width, height = _image_size(image)
    return types.SimpleNamespace(width=width, height=height, cache_hit=False, cache_status="missing",
                                 sample_hash="fake", num_textons=0)


def cache_status(image, *, cache_dir, **params):
    _image_size(image)
    return "missing"


def expected_uv(positions, corner_verts, scale, width):
    """Planar XY projection in texels, wrapped into the sample (the double's whole 'synthesis')."""
    xy = positions[corner_verts, :2].astype(np.float64) * scale / width
    return np.mod(xy, 1.0).astype(np.float32)


def synthesize_jumpmap(pre, positions, corner_verts, poly_starts, poly_sizes, *, scale, blend=True,
                       seed=0, **options):
    positions = np.asarray(positions)
    if positions.dtype != np.float32 or positions.ndim != 2 or positions.shape[1] != 3:
        raise ValueError("positions must be (N,3) float32")
    for name, array in (("corner_verts", corner_verts), ("poly_starts", poly_starts), ("poly_sizes", poly_sizes)):
        if np.asarray(array).dtype != np.int32:
            raise ValueError("%s must be int32" % name)
    if corner_verts.size and (corner_verts.min() < 0 or corner_verts.max() >= len(positions)):
        raise ValueError("corner_verts index out of range")
    if np.any(poly_sizes < 3) or int(poly_sizes.sum()) != len(corner_verts):
        raise ValueError("poly sizes do not cover the corners")
    base = expected_uv(positions, corner_verts, scale, pre.width)
    corners = len(corner_verts)
    result = {"base_uv": base, "stats": {"faces": len(poly_starts), "vertices": len(positions),
                                          "corners": corners, "jumps": 0}}
    sets = (3 if np.all(poly_sizes == 3) else 4) if blend else 1  # no blending: one set = base, weight 1
    result["num_blend_sets"] = sets
    result["blend_uv"] = np.stack([np.mod(base + 0.125 * k, 1.0) for k in range(sets)]).astype(np.float32)
    weights = np.zeros((corners, sets), np.float32)
    weights[np.arange(corners), corner_verts % sets] = 1.0
    result["blend_weights"] = weights
    return result


def load_image(path):
    width, height = _image_size(path)
    return np.zeros((height, width, 4), np.float32)


def image_info(path):
    width, height = _image_size(path)
    return dict(width=width, height=height, channels=4, format="png", data_type="uint8")


def synthesize_texton(pre, sample_pixels, positions, corner_verts, poly_starts, poly_sizes, *, scale, blend=True,
                      seed=0, camera_position=None, blend_threshold=None, lambda_=1.0, **options):
    """The jump-map double's maps plus per-corner edge data: every other corner blended, E_t = 0.001·corner."""
    pixels = np.asarray(sample_pixels)
    if pixels.ndim != 3 or pixels.shape[:2] != (pre.height, pre.width):
        raise ValueError("sample_pixels must be the preprocessed image (H, W, C)")
    if blend_threshold is not None and camera_position is None:
        raise ValueError("blend_threshold needs camera_position")
    result = synthesize_jumpmap(pre, positions, corner_verts, poly_starts, poly_sizes, scale=scale, blend=blend,
                                seed=seed)
    corners = len(corner_verts)
    result["corner_edge_blended"] = np.arange(corners) % 2 == 0
    result["corner_edge_error"] = (np.arange(corners) * 0.001).astype(np.float32)
    result["stats"].update(blended_edges=corners // 2, searched_faces=len(poly_starts) - 1)
    return result


def histogram_transform(image, *, cache_dir=None, lut_size=1024, **options):
    """Stands in for the Gaussianization: two tiny grey PNGs (the shader only needs images to exist)."""
    import os

    import bpy
    _image_size(image)
    paths = []
    for name, size in (("fake.gauss.png", (4, 4)), ("fake.lut.png", (16, 1))):
        path = os.path.join(cache_dir, name)
        if not os.path.exists(path):
            fake = bpy.data.images.new("fake histogram image", *size)
            fake.filepath_raw, fake.file_format = path, "PNG"
            fake.save()
            bpy.data.images.remove(fake)
        paths.append(path)
    return {"ok": True, "fallback_reason": "", "gaussian_path": paths[0], "lut_path": paths[1]}
