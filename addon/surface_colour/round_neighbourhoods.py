# SPDX-License-Identifier: GPL-3.0-or-later
"""Round-shaped neighbourhoods (Chen & Dong 2008) on one mesh, bpy-free: the direction-invariant context
(points, rings, order) kept for re-synthesis, and the native synthesis call."""
import hashlib

import numpy as np

from .. import native
from ..core.jobs import BoundedCache
from ..core.orientation import directions
from ..core.settings import SettingsError
from .core import smallest_sample_side, target_density, working_sample


class ContextCache(BoundedCache):
    """The last direction-invariant context (points, rings, order): a new field, seed or sample on the
    same mesh, UV map, target and scale re-synthesizes without rebuilding it (the paper's point:
    neighbourhoods do not depend on the field). One only (BoundedCache's capacity 1), since a 1024² context
    holds ~0.3 GB."""

    @staticmethod
    def key(mesh_arrays, triangles, corner_uvs, target, texels_per_unit, settings):
        digest = hashlib.blake2b(digest_size=20)
        for array in (mesh_arrays.positions, triangles, corner_uvs, mesh_arrays.scale_multiplier):
            if array is None:
                digest.update(b"-")
            else:
                array = np.ascontiguousarray(array)
                digest.update(str(array.shape).encode())
                digest.update(array.data)
        digest.update(repr((target.kind, target.width, target.height, target.margin, float(texels_per_unit),
                            settings.round_levels, settings.round_coarse_rings,
                            settings.round_fine_rings)).encode())
        return digest.hexdigest()


contexts = ContextCache()


def synthesize_round(sample, mesh_arrays, triangles, corner_uvs, settings, seed, texels_per_unit, target,
                     cancel=None, cache=contexts, stage=None):
    """Round-neighbourhood synthesis on one mesh. sample: synthesis_sample() output. Returns the native
    dict plus 'context_reused' and 'stats' (seconds of each part). ValueError (SettingsError or the
    native module's) on bad input, e.g. overlapping UV islands or a target above the memory limit."""
    module = native.require()
    if mesh_arrays.num_faces == 0 or triangles.shape[0] == 0:
        raise SettingsError("mesh has no faces")
    up = directions(mesh_arrays, settings)
    density = target_density(mesh_arrays.positions, triangles, corner_uvs, target)
    full_width = sample.shape[1]
    sample, texels_per_unit = working_sample(sample, texels_per_unit, density, settings.round_resolution,
                                             smallest_sample_side(settings))
    key = cache.key(mesh_arrays, triangles, corner_uvs, target, texels_per_unit, settings)
    context = cache.get(key)
    reused = context is not None
    extra = {} if cancel is None else {"cancel": cancel}
    stage = stage or (lambda name: None)
    if context is None:
        stage("context")
        context = module.RoundSynthesisContext(
            mesh_arrays.positions, triangles, corner_uvs if target.kind == "IMAGE" else None,
            target="image" if target.kind == "IMAGE" else "vertices", width=int(target.width),
            height=int(target.height), margin=int(target.margin), texels_per_unit=float(texels_per_unit),
            scale_multiplier=mesh_arrays.scale_multiplier, levels=settings.round_levels,
            coarse_rings=settings.round_coarse_rings, fine_rings=settings.round_fine_rings, **extra)
        cache.put(key, context)
    stage("synthesis")
    result = dict(module.round_synthesize(context, sample, up, seed=int(seed),
                                          random_candidates=settings.round_candidates,
                                          tileable=bool(settings.tileable), **extra))
    native_stats = dict(result.get("stats") or {})
    context_stats = dict(context.stats)
    result["context_reused"] = reused
    result["stats"] = {
        "seconds_context": 0.0 if reused else float(context_stats.get("seconds_total", 0.0)),
        "seconds_synthesis": float(native_stats.get("seconds_total", 0.0)),
        "context_reused": reused,
        "surface_samples": int(context.num_points),
        "overlapping_texels": int(context_stats.get("overlapping_texels", 0)),
        "working_sample": [int(sample.shape[1]), int(sample.shape[0])],
        "target_density": density,
        # sample pixels per surface sample spacing before any reduction (> 1: the target is coarser)
        "sample_pixels_per_spacing": float(full_width / float(sample.shape[1]) * texels_per_unit / density)
        if density > 0.0 else 0.0,
        "levels": [dict(level) for level in native_stats.get("levels", [])],
    }
    return result
