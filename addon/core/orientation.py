# SPDX-License-Identifier: GPL-3.0-or-later
"""The texture's orientation per vertex, from the orientation settings every method shares (axis, field or
anchors), computed by the native field solver (bpy-free)."""
import numpy as np

from .. import native
from .settings import SettingsError


def directions(mesh_arrays, settings):
    """Per-vertex unit 'up' of the texture (V, 3), from the same orientation settings as the UV methods."""
    module = native.require()
    mesh = (mesh_arrays.positions, mesh_arrays.corner_verts, mesh_arrays.poly_starts, mesh_arrays.poly_sizes)
    if settings.orientation == "AXIS":
        return module.compute_field(*mesh, orientation="axis", axis=tuple(float(c) for c in settings.axis))
    if mesh_arrays.direction is None:
        raise SettingsError("mesh has no vector attribute %r for the orientation" % settings.direction_attribute)
    if settings.orientation == "FIELD":
        return module.compute_field(*mesh, orientation="field", direction=mesh_arrays.direction)
    anchors = np.flatnonzero(np.linalg.norm(mesh_arrays.direction, axis=1) > 1e-12).astype(np.int32)
    if anchors.size == 0:
        raise SettingsError("attribute %r has no non-zero vectors: no anchors" % settings.direction_attribute)
    return module.compute_field(*mesh, orientation="anchors", anchor_vertices=anchors,
                                anchor_directions=np.ascontiguousarray(mesh_arrays.direction[anchors]))
