# SPDX-License-Identifier: GPL-3.0-or-later
"""A mesh's direction field as TexSynth stores it (guide strokes, singularities, the relaxed direction, all
in object space as point attributes) and its scale multiplier, read and written through the bridge."""
import numpy as np

from ..bridge import mesh_io
from ..core.settings import SettingsError
from . import authoring


def _linear(obj):
    return np.array(obj.matrix_world, dtype=np.float64)[:3, :3]


def read_field_state(obj, axis=(0.0, 0.0, 1.0)):
    """authoring.FieldState of obj (world space). A mesh without field attributes gets an empty guide,
    no singularities and a direction relaxed from them (the axis)."""
    mesh = obj.data
    arrays = mesh_io.read_mesh(obj)
    n = arrays.num_vertices
    linear = _linear(obj)
    guide = mesh_io.read_point_attribute(mesh, authoring.GUIDE_NAME, "FLOAT_VECTOR")
    guide = np.zeros((n, 3), np.float32) if guide is None else (guide @ linear.T).astype(np.float32)
    singularity = mesh_io.read_point_attribute(mesh, authoring.SINGULARITY_NAME, "INT")
    singularity = np.zeros(n, np.int32) if singularity is None else np.clip(singularity, -1, 1).astype(np.int32)
    direction = mesh_io.read_point_attribute(mesh, authoring.DIRECTION_NAME, "FLOAT_VECTOR")
    state = authoring.FieldState(arrays, guide, singularity,
                              None if direction is None else (direction @ linear.T).astype(np.float32), tuple(axis))
    if state.direction is None:
        authoring.relax(state)
    return state


def field_attributes(obj, state):
    """{name: (data_type, values)} of the field attributes as write_field_state stores them (object
    space, the stored dtypes): computed before writing, so a live update can start synthesizing from
    exactly the stored direction while the main thread writes."""
    if state.arrays.num_vertices != len(obj.data.vertices):
        raise SettingsError("mesh %r changed while its field was edited" % obj.data.name)
    inverse = np.linalg.inv(_linear(obj)) if abs(np.linalg.det(_linear(obj))) > 1e-30 else np.eye(3)
    return {authoring.GUIDE_NAME: ("FLOAT_VECTOR", (state.guide @ inverse.T).astype(np.float32)),
            authoring.SINGULARITY_NAME: ("INT", np.ascontiguousarray(state.singularity, dtype=np.int32)),
            authoring.DIRECTION_NAME: ("FLOAT_VECTOR", (state.direction @ inverse.T).astype(np.float32))}


def write_field_attributes(obj, attributes):
    """Writes field_attributes(obj, state)."""
    mesh = obj.data
    for name, (data_type, values) in attributes.items():
        mesh_io.write_point_attribute(mesh, name, data_type, values)
    mesh.update()


def write_field_state(obj, state):
    """Stores guide, singularities and direction on obj's mesh (object space)."""
    write_field_attributes(obj, field_attributes(obj, state))


def read_scale_multiplier(obj, settings):
    """Per-vertex density multiplier from settings.scale_source, or None."""
    source = getattr(settings, "scale_source", "NONE")
    if source == "ATTRIBUTE":
        values = mesh_io.read_point_attribute(obj.data, settings.scale_attribute, "FLOAT")
        if values is None:
            raise SettingsError("mesh %r has no scale attribute %r" % (obj.data.name, settings.scale_attribute))
        try:
            return authoring.check_scale_multiplier(values, "attribute %r" % settings.scale_attribute)
        except ValueError as error:
            raise SettingsError(str(error))
    if source == "VERTEX_GROUP":
        weights = mesh_io.read_vertex_group(obj, settings.scale_group)
        return authoring.scale_from_weights(weights, settings.scale_min, settings.scale_max)
    return None


# Per object name: (authoring.mesh_key, RayCaster, FieldMesh), rebuilt when the mesh changes.
_native_meshes = {}


def _native_mesh(obj, arrays, which):
    key = authoring.mesh_key(arrays)
    cached = _native_meshes.get(obj.name)
    if cached is None or cached[0] != key:
        cached = [key, None, None]
        _native_meshes[obj.name] = cached
    if cached[which] is None:
        cached[which] = authoring.ray_caster(arrays) if which == 1 else authoring.field_mesh(arrays)
    return cached[which]


def caster_for(obj, arrays):
    """The object's native ray caster, rebuilt only when its mesh changed."""
    return _native_mesh(obj, arrays, 1)


def field_mesh_for(obj, arrays):
    """The object's native field mesh (relaxation), rebuilt only when its mesh changed."""
    return _native_mesh(obj, arrays, 2)


def field_state(context, obj):
    """The active edit's FieldState, with the object's cached native field mesh."""
    state = read_field_state(obj, tuple(context.scene.texsynth.axis))
    state.field_mesh = field_mesh_for(obj, state.arrays)
    return state


PRESETS = ("AXIS", "CURVATURE", "SMOOTH")


def preset_field(obj, preset, axis, iterations=10):
    """obj's field state (read from the mesh; axis: the fallback direction) with a preset applied, not
    written yet: the Field Preset operator and the CLI's --field-preset."""
    state = read_field_state(obj, tuple(axis))
    state.field_mesh = field_mesh_for(obj, state.arrays)
    if preset == "AXIS":
        authoring.preset_axis(state, tuple(axis))
    elif preset == "CURVATURE":
        authoring.preset_curvature(state)
    elif preset == "SMOOTH":
        authoring.preset_smooth(state, iterations)
    else:
        raise SettingsError("unknown field preset %r (choose one of %s)" % (preset, ", ".join(PRESETS)))
    return state
