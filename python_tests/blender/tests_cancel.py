# SPDX-License-Identifier: GPL-3.0-or-later
"""Cancellation inside Blender: Run: blender -b --factory-startup --python-exit-code 1 --python <this>

The Synthesize operator, invoked from the UI, runs the native work in a worker thread (ModalSynthesis)
and polls it from modal(); Esc cancels. Background Blender has no event loop, so these tests drive
the same objects the operator uses: a real Job on a large mesh cancelled mid-run, and modal() fed
Esc / timer events. Prints "CANCEL latency_ms=..." for the README figure.
"""
import os
import sys
import time
import types

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bpy  # noqa: E402
import numpy as np  # noqa: E402

import harness  # noqa: E402

texsynth = harness.load_addon()
from texsynth.ui import modal_jobs, operators  # noqa: E402
from texsynth.uv_methods import synthesis  # noqa: E402
from texsynth.bridge import sources  # noqa: E402
from texsynth.core import jobs  # noqa: E402

texsynth.register()
BRICKS = os.path.join(harness.SAMPLES_DIR, "bricks.png")


def big_grid(side=700):
    """side x side quads (490k faces at 700) with a foreign UV map, built with foreach_set."""
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
    for mesh in list(bpy.data.meshes):
        bpy.data.meshes.remove(mesh)
    xs, ys = np.meshgrid(np.arange(side + 1, dtype=np.float32), np.arange(side + 1, dtype=np.float32))
    positions = np.stack([xs.ravel(), ys.ravel(), np.zeros(xs.size, np.float32)], 1) * 0.01
    qx, qy = np.meshgrid(np.arange(side, dtype=np.int32), np.arange(side, dtype=np.int32))
    v00 = (qy * (side + 1) + qx).ravel()
    corners = np.stack([v00, v00 + 1, v00 + side + 2, v00 + side + 1], 1).ravel().astype(np.int32)
    obj = harness.mesh_from_arrays("Big", positions, corners, np.arange(side * side, dtype=np.int32) * 4,
                                   np.full(side * side, 4, np.int32))
    obj.data.uv_layers.new(name="UVMap")
    return obj


def settings():
    props = bpy.context.scene.texsynth
    props.sample_source, props.sample_path, props.scale, props.blend = "FILE", BRICKS, 2.0, True
    return props


def new_job(obj, method="JUMPMAP"):
    props = settings()
    props.method = method
    return synthesis.Job([obj], sources.Sample(path=BRICKS), props.to_settings(), None, "NEW").prepare()


def test_cancelled_job_stops_fast_and_writes_nothing():
    check_cancelled_job("JUMPMAP", 0.02)


def test_cancelled_texton_job_stops_fast_and_writes_nothing():
    # Past the mesh build, inside the texton growth. Coherent candidates made the growth 3x faster (a
    # 490k-face grid finished within 0.5 s on a fast machine), hence 1M faces and an earlier cancel.
    check_cancelled_job("TEXTON", 0.6, side=1000)


def check_cancelled_job(method, delay, side=700):
    """Cancels `delay` seconds after the synthesis started (preprocessing is a cache hit)."""
    obj = big_grid(side)
    before = harness.mesh_hash(obj.data)
    new_job(obj).compute()  # warms the preprocessing cache (jump map: quick): the run below is pure synthesis
    job = new_job(obj, method)
    state = modal_jobs.ModalSynthesis(job).start()
    deadline = time.perf_counter() + 30
    while state.fraction < 0.1 and state.running() and time.perf_counter() < deadline:
        time.sleep(0.001)  # until preprocessing (a cache hit) is done and the synthesis has started
    time.sleep(delay)
    assert state.running(), "the synthesis finished before it could be cancelled: use a larger mesh"
    cancelled_at = time.perf_counter()
    job.cancel()
    try:
        state.finish(timeout=30)
        raise AssertionError("a cancelled job must raise")
    except jobs.Cancelled:
        pass
    latency = time.perf_counter() - cancelled_at
    print("CANCEL %s latency_ms=%.1f faces=%d" % (method, 1e3 * latency, len(obj.data.polygons)), flush=True)
    assert not state.running()
    # The native call itself stopped: it never produced a result (a call that ran to the end and was
    # only discarded afterwards would have left one here).
    assert job.items[0][2] is None, "the %s synthesis ran to completion instead of stopping" % method
    try:
        job.apply()
        raise AssertionError("apply() after cancel must raise")
    except jobs.Cancelled:
        pass
    assert harness.mesh_hash(obj.data) == before
    assert len(obj.material_slots) == 0


class FakeWindowManager:
    def __init__(self):
        self.calls = []

    def __getattr__(self, name):
        return lambda *args, **kwargs: self.calls.append(name)


def drive_modal(job, events):
    """Calls the operator's modal() as Blender would, with a stand-in operator and context."""
    reports = []
    fake_self = types.SimpleNamespace(_job_state=modal_jobs.ModalSynthesis(job).start(), _timer=None,
                                      report=lambda kind, text: reports.append((kind, text)))
    fake_self._finish = lambda job_: operators.TEXSYNTH_OT_synthesize._finish(fake_self, job_)
    context = types.SimpleNamespace(window_manager=FakeWindowManager(), workspace=None)
    result = None
    for event_type in events:
        result = operators.TEXSYNTH_OT_synthesize.modal(fake_self, context, types.SimpleNamespace(
            type=event_type, value="PRESS"))
    while result == {"RUNNING_MODAL"}:
        time.sleep(modal_jobs.ModalSynthesis.POLL_SECONDS)
        result = operators.TEXSYNTH_OT_synthesize.modal(fake_self, context, types.SimpleNamespace(
            type="TIMER", value="NOTHING"))
    return result, reports


def test_modal_escape_cancels_and_changes_nothing():
    obj = big_grid()
    before = harness.mesh_hash(obj.data)
    result, reports = drive_modal(new_job(obj), ["MOUSEMOVE", "ESC"])
    assert result == {"CANCELLED"}, result
    assert reports and "cancelled" in reports[-1][1].lower(), reports
    assert harness.mesh_hash(obj.data) == before


def test_modal_run_to_completion_writes_and_one_undo_restores():
    obj = big_grid(60)
    before = harness.mesh_hash(obj.data)
    bpy.ops.ed.undo_push(message="before TexSynth")
    result, reports = drive_modal(new_job(obj), ["TIMER"])
    assert result == {"FINISHED"}, reports
    assert "TexSynth" in bpy.data.objects["Big"].data.uv_layers
    bpy.ops.ed.undo_push(message="TexSynth")  # what Blender does after a FINISHED modal operator with UNDO
    bpy.ops.ed.undo()
    assert harness.mesh_hash(bpy.data.objects["Big"].data) == before


def round_job(side, size):
    """Round neighbourhoods on a side x side grid (0.01 units per quad) with a planar UV map, into a
    size² image; the sample at its own density is reduced to the target's."""
    from texsynth.core import bake_options as options
    from texsynth.surface_colour import core, synthesis as surface
    from texsynth.surface_colour import round_neighbourhoods as round_core
    obj = big_grid(side)
    mesh = obj.data
    corner_verts = np.empty(len(mesh.loops), np.int32)
    mesh.loops.foreach_get("vertex_index", corner_verts)
    positions = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", positions)
    uv = positions.reshape(-1, 3)[corner_verts, :2] / (0.01 * side)
    mesh.uv_layers["UVMap"].data.foreach_set("uv", np.ascontiguousarray(uv).ravel())
    props = settings()
    props.method, props.scale = "ROUND", 0.01 * side * 192 / size
    round_core.contexts.clear()
    request = options.BakeRequest(size=size, margin=2, create_uv=False)
    return obj, surface.Job([obj], sources.Sample(path=BRICKS), props.to_settings(), request, "NEW")


def test_round_modal_progress_advances_and_escape_cancels_leaving_nothing():
    obj, job = round_job(200, 512)
    before = (harness.mesh_hash(obj.data), sorted(i.name for i in bpy.data.images), len(bpy.data.materials))
    state = modal_jobs.ModalSynthesis(job.prepare()).start()
    seen = []
    deadline = time.perf_counter() + 60
    while state.running() and time.perf_counter() < deadline and len(set(seen)) < 4:
        seen.append(round(state.live_fraction(), 3))
        time.sleep(0.02)
    assert state.running(), "the round synthesis finished before it could be cancelled: use a larger target"
    assert len(set(seen)) >= 4 and seen == sorted(seen) and 0.0 <= seen[0] and seen[-1] < 1.0, seen
    job.cancel()
    try:
        state.finish(timeout=30)
        raise AssertionError("a cancelled round job must raise")
    except jobs.Cancelled:
        pass
    job.discard()
    assert job.items[0].result is None
    assert (harness.mesh_hash(obj.data), sorted(i.name for i in bpy.data.images), len(bpy.data.materials)) == before


def test_round_modal_run_to_completion_and_one_undo_removes_the_image():
    obj, job = round_job(40, 64)
    bpy.ops.ed.undo_push(message="before TexSynth")
    images = sorted(i.name for i in bpy.data.images)
    result, reports = drive_modal(job.prepare(), ["TIMER"])
    assert result == {"FINISHED"}, reports
    assert "TexSynth Round: Big" in bpy.data.images
    bpy.ops.ed.undo_push(message="TexSynth")
    bpy.ops.ed.undo()
    assert sorted(i.name for i in bpy.data.images) == images
    assert not bpy.data.objects["Big"].material_slots


harness.Checks().run([test_cancelled_job_stops_fast_and_writes_nothing, test_cancelled_texton_job_stops_fast_and_writes_nothing,
                      test_modal_escape_cancels_and_changes_nothing,
                      test_modal_run_to_completion_writes_and_one_undo_restores,
                      test_round_modal_progress_advances_and_escape_cancels_leaving_nothing,
                      test_round_modal_run_to_completion_and_one_undo_removes_the_image], harness.script_args())
