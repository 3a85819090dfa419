# SPDX-License-Identifier: GPL-3.0-or-later
"""What TexSynth writes on a mesh: its UV map and corner attributes, and the mesh arrays it reads (bpy-free)."""
import dataclasses

import numpy as np

from .settings import SettingsError


MAX_UV_LAYERS = 8  # Blender's hard limit per mesh
BASE_UV_NAME = "TexSynth"  # TexSynth's only UV map: the base mapping (normal-map tangents, no-blend look)
# Before 0.2 the blend sets were UV maps TexSynth_B0..B3 (5 of Blender's 8): recognised, so Synthesize
# replaces them and Clear removes them.
LEGACY_BLEND_UV_PREFIX = "TexSynth_B"
# Blend set coordinates per corner, two sets per RGBA corner attribute: (u0, v0, u1, v1), (u2, v2, u3, v3).
# Interpolated exactly like UV maps, without using any of Blender's 8 UV map slots.
SET_ATTRIBUTE_NAMES = ("TexSynth_Sets01", "TexSynth_Sets23")
WEIGHTS_NAME = "TexSynth_Weights"
# Texton method, per corner (the edge from the corner to the next): 1 where that edge is blended, and its E_t.
EDGE_BLENDED_NAME = "TexSynth_EdgeBlended"
EDGE_ERROR_NAME = "TexSynth_EdgeError"
EXTRA_ATTRIBUTE_NAMES = (EDGE_BLENDED_NAME, EDGE_ERROR_NAME)
# Texton results: per corner, the weights summed per group of identical mappings (mapping_groups_rgba).
GROUPS_NAME = "TexSynth_Groups"
ATTRIBUTE_NAMES = (WEIGHTS_NAME,) + SET_ATTRIBUTE_NAMES + (GROUPS_NAME,) + EXTRA_ATTRIBUTE_NAMES
MAX_BLEND_SETS = 4  # the weight attribute is RGBA


@dataclasses.dataclass
class MeshArrays:
    """A mesh in Blender's layout, world space, ready for the native module."""
    positions: np.ndarray          # (N,3) float32
    corner_verts: np.ndarray       # (L,) int32
    poly_starts: np.ndarray        # (P,) int32
    poly_sizes: np.ndarray         # (P,) int32
    direction: np.ndarray = None   # (N,3) float32, world space (FIELD / ANCHORS)
    scale_multiplier: np.ndarray = None  # (N,) float32 > 0, or None

    @property
    def num_vertices(self):
        return int(self.positions.shape[0])

    @property
    def num_corners(self):
        return int(self.corner_verts.shape[0])

    @property
    def num_faces(self):
        return int(self.poly_starts.shape[0])


def is_texsynth_uv_name(name):
    """TexSynth's UV map, or a blend-set UV map of an older TexSynth (TexSynth_B0..B3)."""
    if name == BASE_UV_NAME:
        return True
    suffix = name[len(LEGACY_BLEND_UV_PREFIX):]
    return name.startswith(LEGACY_BLEND_UV_PREFIX) and suffix.isdigit()


def check_uv_capacity(existing_names):
    """Raises SettingsError when the mesh has no room for TexSynth's one UV map (its own are replaced)."""
    foreign = [name for name in existing_names if not is_texsynth_uv_name(name)]
    if len(foreign) + 1 > MAX_UV_LAYERS:
        raise SettingsError(
            "mesh has %d other UV maps (%s) and Blender allows at most %d: remove one so TexSynth can add its UV map"
            % (len(foreign), ", ".join(foreign), MAX_UV_LAYERS))
