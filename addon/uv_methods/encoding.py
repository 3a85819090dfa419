# SPDX-License-Identifier: GPL-3.0-or-later
"""A UV-method result as the corner attributes the blend node group reads: checks before anything is
written, blend-set coordinates, weights and texton mapping groups (bpy-free)."""

import numpy as np

from ..core.finite import all_finite
from ..core.layers import EXTRA_ATTRIBUTE_NAMES, MAX_BLEND_SETS
from ..core.settings import SettingsError


def check_result(result, num_corners, finite=True):
    """Validates a synthesizer result before anything is written (so a bad one changes nothing).
    finite=False checks shapes and dtypes only (the caller scans for NaN/inf with FiniteScan)."""
    base = result["base_uv"]
    sets = int(result["num_blend_sets"])
    if not (0 <= sets <= MAX_BLEND_SETS):
        raise SettingsError("native result has %d blend sets (at most %d supported)" % (sets, MAX_BLEND_SETS))
    expected = {"base_uv": (num_corners, 2)}
    if sets:
        expected.update(blend_weights=(num_corners, sets))
        if result.get("blend_set_pairs") is not None:
            expected.update(blend_set_pairs=((sets + 1) // 2, num_corners, 4))
        else:
            expected.update(blend_uv=(sets, num_corners, 2))
    for key, shape in expected.items():
        array = result[key]
        if array.shape != shape or array.dtype != np.float32:
            raise SettingsError("native result %s has shape %s %s, expected %s float32"
                                % (key, array.shape, array.dtype, shape))
        if finite and not all_finite(array):
            raise SettingsError("native result %s contains NaN or infinite values" % key)
    return base


def corner_attributes(result, num_corners, finite=True):
    """The method's extra per-corner FLOAT attributes {name: (L,) float32}, checked before writing
    (finite=False: shapes and dtypes only)."""
    extras = result.get("corner_attributes") or {}
    for name, values in extras.items():
        if name not in EXTRA_ATTRIBUTE_NAMES:
            raise SettingsError("native result has an unknown corner attribute %r" % name)
        if values.shape != (num_corners,) or values.dtype != np.float32 or (finite and not all_finite(values)):
            raise SettingsError("native result %s must be finite float32 of shape (%d,)" % (name, num_corners))
    return extras


def mapping_groups_rgba(result, poly_starts, poly_sizes, tolerance=1e-6):
    """Texton blending's variance in four numbers per corner, as a flat float32 RGBA buffer.

    Per polygon, the blend sets fall into groups of identical mappings: group 0 = the sets equal to
    the polygon's own patch (the base mapping), groups 1..3 the other distinct mappings (a 4th
    distinct one, possible on quads only, shares group 3). A set k in group g adds its weight w_k to
    channel g. Groups are constant over a polygon and the weights are interpolated linearly, so the
    interpolated channels are the groups' total weights G_g anywhere inside it, and the shader gets
    the blend's variance, with identical mappings fully correlated and distinct ones independent, as
    (b + (1 - b) G_0)^2 + (1 - b)^2 (G_1^2 + G_2^2 + G_3^2) (b: the base's fade-in weight): a few
    nodes instead of the pairwise correlations (render cost). Alpha holds G_3 itself: a mesh without
    the attribute reads (0, 0, 0, 1), i.e. all set weight in one independent group, a safe variance."""
    sets = int(result["num_blend_sets"])
    weights = np.asarray(result["blend_weights"], dtype=np.float32)
    base = result["base_uv"]
    num_corners = base.shape[0]
    pairs = result.get("blend_set_pairs")
    set_uv = ([pairs[k // 2][:, 2 * (k % 2):2 * (k % 2) + 2] for k in range(sets)] if pairs is not None
              else [result["blend_uv"][k] for k in range(sets)])
    starts = np.asarray(poly_starts, dtype=np.int64)
    sizes = np.asarray(poly_sizes, dtype=np.int64)

    def per_polygon_all(flags):
        return np.logical_and.reduceat(flags, starts) if starts.size else np.zeros(0, bool)

    def same(a, b):
        return per_polygon_all(np.all(np.abs(a - b) <= tolerance, axis=1))

    used = [np.logical_or.reduceat(weights[:, k] > 0, starts) if starts.size else np.zeros(0, bool)
            for k in range(sets)]
    group = []
    next_id = np.ones(starts.size, np.int64)
    for k in range(sets):
        g = np.where(same(set_uv[k], base), 0, -1)
        for j in range(k):
            join = (g < 0) & used[j] & same(set_uv[j], set_uv[k])
            g[join] = group[j][join]
        new = (g < 0) & used[k]
        g[new] = np.minimum(next_id[new], 3)
        next_id[new] += 1
        group.append(np.maximum(g, 0))
    corner_poly = np.repeat(np.arange(starts.size), sizes)
    rgba = np.zeros((num_corners, 4), dtype=np.float32)
    rows = np.arange(num_corners)
    for k in range(sets):
        rgba[rows, group[k][corner_poly]] += weights[:, k]
    return rgba.ravel()


def blend_set_rgba(result, num_corners):
    """The blend-set coordinates as two flat float32 RGBA corner buffers: (u0, v0, u1, v1) and
    (u2, v2, u3, v3); unused sets (3-set results) are 0. Views of the native result when it came
    packed (blend_set_pairs), else a repacking copy."""
    sets = int(result["num_blend_sets"])
    pairs = result.get("blend_set_pairs")
    if pairs is not None:
        return [pairs[k].ravel() for k in range(2)] if pairs.shape[0] == 2 else \
            [pairs[0].ravel(), np.zeros(num_corners * 4, np.float32)]
    blend_uv = result["blend_uv"]
    buffers = []
    for first in (0, 2):
        rgba = np.zeros((num_corners, 2, 2), dtype=np.float32)
        for k in range(first, min(first + 2, sets)):
            rgba[:, k - first, :] = blend_uv[k]
        buffers.append(rgba.ravel())
    return buffers


def weights_rgba(result, num_corners, consume=False):
    """The blend weights as a flat float32 RGBA corner buffer: R, G, B = w0, w1, w2 and A = 1 - w3.

    Alpha holds 1 - w3 (not w3) because shaders read a missing attribute as (0, 0, 0, 1): a mesh
    without weights then gets all-zero weights and the node group falls back to the base mapping.
    Unused channels are 0 (alpha 1). consume=True (4 sets) converts result["blend_weights"] in place
    and takes it out of `result`, saving a corner-sized copy on big meshes."""
    sets = int(result["num_blend_sets"])
    weights = result["blend_weights"]
    if sets == 4 and consume and weights.dtype == np.float32 and weights.flags.c_contiguous and weights.flags.writeable:
        result["blend_weights"] = None  # now RGBA: must not be read as weights again
        np.subtract(1.0, weights[:, 3], out=weights[:, 3])
        return weights.ravel()
    if sets == 4:  # one contiguous copy, then flip the alpha column
        rgba = np.array(weights, dtype=np.float32, order="C", copy=True)
        np.subtract(1.0, rgba[:, 3], out=rgba[:, 3])
        return rgba.ravel()
    rgba = np.zeros((num_corners, 4), dtype=np.float32)
    rgba[:, 3] = 1.0
    if sets:
        rgba[:, :sets] = result["blend_weights"]
    return rgba.ravel()
