# SPDX-License-Identifier: GPL-3.0-or-later
"""What happens after each field edit: the field is written, the overlay refreshed and, with Live Update, the
object re-synthesized.

With Live Update the re-synthesis starts from the edit's in-memory FieldState (mesh arrays and the
direction exactly as stored), and the field attribute writes run on the main thread while the
synthesizer works in a worker thread (see commit_edit). TEXSYNTH_LIVE_PATH=full keeps the previous
sequence (write the field, then a Synthesize that re-reads the mesh), the benchmarks' baseline;
TEXSYNTH_LIVE_PATH=sequential is the in-memory path without the worker thread.
"""
import os
import time

import numpy as np

from .. import methods
from ..bridge import mesh_io
from ..core.layers import MeshArrays
from ..core.settings import SettingsError
from ..fields import authoring, mesh_state, overlay
from ..surface_colour import synthesis as surface_synthesis
from ..uv_methods import synthesis
from . import modal_jobs, properties


# "full": live updates take the pre-overlap path (write the field, then re-read and re-synthesize);
# "sequential": from memory, no worker thread.
LIVE_PATH_ENV = "TEXSYNTH_LIVE_PATH"
# Preprocessed samples kept in memory for live updates: key -> Preprocessed.
_live_samples = {}
# Per object name, during a Comb session only: the snapshot of its last live update, whose buffers
# the next one reads the replaced layers into (no fresh pages per stroke).
_live_snapshots = {}
# Figures of the last edit / live update, shown by the panel and read by tests and benchmarks.
last_timings = {}


def release_live_buffers(name):
    """Ends a Comb session's claim on the buffers of its last live update."""
    _live_snapshots.pop(name, None)


def commit_edit(context, obj, state):
    """Writes the edited field, refreshes the overlay and re-synthesizes when Live Update is on.
    Returns a warning when the live update failed (the field edit itself is kept), else None."""
    attributes = mesh_state.field_attributes(obj, state)
    written = []

    def write_field():
        mesh_state.write_field_attributes(obj, attributes)
        written.append(True)

    warning = None
    if not context.scene.texsynth.field_live_update:
        write_field()
    elif os.environ.get(LIVE_PATH_ENV) == "full":
        write_field()
        try:
            live_update(context, obj)
        except (ValueError, RuntimeError) as error:
            warning = "TexSynth live update failed: %s" % error
    else:
        try:
            live_update(context, obj, state, attributes, write_field)
        except (ValueError, RuntimeError) as error:
            warning = "TexSynth live update failed: %s" % error
        if not written:  # the live update failed before the field was written: the edit is kept
            write_field()
    overlay.invalidate(obj.name)
    for area in getattr(context.screen, "areas", None) or ():
        if area.type == "VIEW_3D":
            area.tag_redraw()
    return warning


# Vector-field patches preview after a field edit: patch sampling into an image of at most this size
# (the analysed sample stays in memory), so combing gives feedback in a fraction of a second.
PATCH_PREVIEW_SIZE = 256


def _arrays_from_memory(obj, state, attributes):
    """MeshArrays for the synthesizer from the edit's FieldState, with the direction as a
    fresh Synthesize would read it back from the attribute (object space -> world, same float32
    rounding), or None when the mesh no longer matches the state (counts, transform or positions
    changed: the caller then re-reads everything)."""
    a, mesh = state.arrays, obj.data
    if (len(mesh.vertices), len(mesh.loops), len(mesh.polygons)) != (a.num_vertices, a.num_corners, a.num_faces):
        return None
    matrix = np.array(obj.matrix_world, dtype=np.float64)
    # 1 ms per 100k vertices: proves the positions (and transform) the state was read with still hold.
    if not np.array_equal(mesh_io.read_positions(obj, matrix), a.positions):
        return None
    direction = mesh_io.vectors_to_world(attributes[authoring.DIRECTION_NAME][1].reshape(-1, 3), matrix)
    return MeshArrays(a.positions, a.corner_verts, a.poly_starts, a.poly_sizes, direction=direction)


def live_update(context, obj, state=None, attributes=None, write_field=None):
    """Re-synthesizes obj with the sample kept in memory.

    Without state: reads the mesh and the field just written (the previous path). With the edit's
    FieldState, its field_attributes and the function that writes them (commit_edit): the jump-map
    method synthesizes from memory in a worker thread while write_field() runs on the main thread
    (write_field is called in every case, before this returns or raises, unless a settings error
    stops the update first). UV methods only rewrite the UV layers and weights (materials are left
    as they are); vector-field patches rewrite the object's image at preview size (Synthesize makes
    the full-size one)."""
    props = context.scene.texsynth
    settings = props.to_settings()
    if settings.orientation == "AXIS":
        settings.orientation, settings.direction_attribute = "FIELD", authoring.DIRECTION_NAME
    spec = methods.get(settings.method)
    if spec.live_update == "PREVIEW":
        if write_field is not None:
            write_field()  # the preview reads the field from the mesh
        return _patch_preview(context, obj, props, settings)
    if spec.live_update != "UV":
        raise SettingsError("live update is not available for %s: press Synthesize" % spec.label)
    settings.validate()
    sample = modal_jobs.sample_from_settings(props)
    cache_dir = properties.cache_dir(context)
    key = (sample.describe(), repr(sorted(settings.preprocess_params().items())), cache_dir)
    pre = _live_samples.get(key)
    if pre is None:
        pre = synthesis.preprocess(sample, settings, cache_dir)
        _live_samples.clear()
        _live_samples[key] = pre
    start = time.perf_counter()
    for name in [name for name in last_timings if name.startswith("live_")]:
        del last_timings[name]
    arrays = None
    if (state is not None and write_field is not None and spec.live_from_memory
            and settings.direction_attribute == authoring.DIRECTION_NAME):
        arrays = _arrays_from_memory(obj, state, attributes)
    last_timings["live_from_memory"] = arrays is not None
    if arrays is not None:
        report = synthesis.synthesize_from_memory(obj, arrays, settings, pre, write_field,
                                                  overlap=os.environ.get(LIVE_PATH_ENV) != "sequential",
                                                  reuse_snapshot=_live_snapshots.pop(obj.name, None))
        _live_snapshots.clear()  # one object edited at a time: keep one set of buffers
        if obj.name in overlay.active_editors:  # only during a Comb session (released by its end)
            _live_snapshots[obj.name] = report.snapshot
        last_timings.update(("live_" + name, value) for name, value in report.seconds.items())
    else:
        if write_field is not None:
            write_field()
        report = synthesis.synthesize([obj], sample, settings, cache_dir, "NONE", preprocessed=pre)
    last_timings["live_update"] = time.perf_counter() - start
    last_timings["live_native"] = report.native_stats.get(obj.name, {}).get("seconds", 0.0)
    if report.failures:
        raise SettingsError(report.summary())
    return report


def _patch_preview(context, obj, props, settings):
    settings.patch_mode = "SAMPLING"
    settings.validate()
    request = props.to_bake_request()
    request.size = min(int(request.size), PATCH_PREVIEW_SIZE)
    request.margin = min(int(request.margin), 4)
    start = time.perf_counter()
    report = surface_synthesis.synthesize([obj], modal_jobs.sample_from_settings(props), settings, request,
                                          props.material_mode, context=context,
                                          cache_dir=properties.cache_dir(context))
    last_timings["live_update"] = time.perf_counter() - start
    last_timings["live_native"] = report.native_stats.get(obj.name, {}).get("seconds_synthesis", 0.0)
    if report.failures:
        raise SettingsError(report.summary())
    return report
