# SPDX-License-Identifier: GPL-3.0-or-later
"""A UV-method result onto its mesh: checked and encoded as the blend node group's corner attributes
(encoding.py), then written atomically by the bridge."""
import os

import numpy as np

from ..bridge import mesh_io, mesh_layers
from ..core.finite import all_finite
from ..core.layers import GROUPS_NAME, SET_ATTRIBUTE_NAMES, WEIGHTS_NAME
from ..core.settings import SettingsError
from .encoding import blend_set_rgba, check_result, corner_attributes, weights_rgba


def write_result(mesh, result, taken_snapshot=None):
    """Writes the base UV map and the corner attributes (blend sets, weights, the method's extras);
    replaces TexSynth's previous layers, including the blend-set UV maps of older versions.

    Foreign UV maps keep their data and flags; the active/render UV map is not changed unless the
    mesh had none. Raises SettingsError (no room for the UV map) or MeshWriteError (restored) and
    then leaves the mesh as it was. Returns the snapshot taken before writing, for mesh_layers.restore().
    Consumes result["blend_weights"] (converted to RGBA in place, to save a corner-sized copy).
    taken_snapshot: mesh_layers.snapshot(mesh) taken since the mesh last changed (else it is taken here).

    Shapes and dtypes are checked first; the scan for NaN/inf (hundreds of MB on a million faces)
    runs in a worker thread while the layers are written and is awaited before the write completes:
    a non-finite result restores the mesh like any failed write (TEXSYNTH_WRITE_CHECK=before: scan
    first, as before).
    """
    num_corners = len(mesh.loops)
    scan_during_write = os.environ.get(mesh_io.WRITE_CHECK_ENV) != "before"
    base = np.ascontiguousarray(check_result(result, num_corners, finite=not scan_during_write),
                                dtype=np.float32).ravel()
    extras = corner_attributes(result, num_corners, finite=not scan_during_write)
    sets = int(result["num_blend_sets"])
    mesh_layers.check_capacity(mesh)
    colors = {}  # FLOAT_COLOR corner attributes to write
    if sets:
        colors.update(zip(SET_ATTRIBUTE_NAMES, blend_set_rgba(result, num_corners)))
        colors[WEIGHTS_NAME] = weights_rgba(result, num_corners, consume=True)
        if result.get("mapping_groups") is not None:
            groups = result["mapping_groups"]
            if groups.shape != (num_corners * 4,) or groups.dtype != np.float32 or \
                    (not scan_during_write and not all_finite(groups)):
                raise SettingsError("mapping groups must be finite float32 of shape (%d,)" % (num_corners * 4))
            colors[GROUPS_NAME] = groups
    return mesh_layers.write_layers(mesh, base, colors, extras, scan_during_write, taken_snapshot)
