# SPDX-License-Identifier: GPL-3.0-or-later
"""Interactive field tools driven by simulated mouse events in a real Blender window (needs a display,
e.g. xvfb-run, and --enable-event-simulate):

  xvfb-run -a blender --factory-startup --enable-event-simulate --python python_tests/blender/gui_fields.py

Checks the Comb modal (started from the sidebar context), Ctrl-drag erase, the Source pick started
from the sidebar, selecting the Comb workspace tool, and that the overlay really draws (GPU batch
built while combing). Prints PASS/FAIL lines and "GUI SUMMARY failed=N", then quits.
"""
import math
import os
import sys
import traceback

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import bpy  # noqa: E402
import numpy as np  # noqa: E402
from bpy_extras import view3d_utils  # noqa: E402

import harness  # noqa: E402

texsynth = harness.load_addon()
texsynth.register()
from texsynth.bridge import mesh_io  # noqa: E402
from texsynth.fields import authoring, overlay  # noqa: E402

failed = []


def view3d():
    window = bpy.context.window_manager.windows[0]
    area = next(a for a in window.screen.areas if a.type == "VIEW_3D")
    region = next(r for r in area.regions if r.type == "WINDOW")
    sidebar = next(r for r in area.regions if r.type == "UI")
    return window, area, region, sidebar


def to_window(region, point):
    """Window pixel coordinates of a world point."""
    xy = view3d_utils.location_3d_to_region_2d(region, region.data, point)
    return int(round(region.x + xy.x)), int(round(region.y + xy.y))


def setup():
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj)
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=40, y_subdivisions=40, size=2.0)
    obj = bpy.context.active_object
    obj.name = "Plane"
    props = bpy.context.scene.texsynth
    props.field_brush_radius, props.field_brush_strength, props.field_erase = 0.25, 1.0, False
    props.axis = (0.0, 1.0, 0.0)
    window, area, region, _ = view3d()
    rv3d = region.data
    rv3d.view_perspective = "ORTHO"
    rv3d.view_rotation = (1.0, 0.0, 0.0, 0.0)  # top view
    rv3d.view_location = (0.0, 0.0, 0.0)
    rv3d.view_distance = 3.0
    area.tag_redraw()
    return obj


def world_direction(obj):
    local = mesh_io.read_point_attribute(obj.data, authoring.DIRECTION_NAME, "FLOAT_VECTOR")
    return local @ np.array(obj.matrix_world, np.float64)[:3, :3].T


def angle_deg(a, b):
    a = a / np.linalg.norm(a, axis=-1, keepdims=True)
    b = np.asarray(b, np.float64) / np.linalg.norm(b)
    return np.degrees(np.arccos(np.clip(a @ b, -1.0, 1.0)))


def drag(window, region, start, end, steps=12, ctrl=False):
    """Yields between simulated events so Blender processes each one."""
    x, y = to_window(region, start)
    window.event_simulate(type="MOUSEMOVE", value="NOTHING", x=x, y=y, ctrl=ctrl)
    yield
    window.event_simulate(type="LEFTMOUSE", value="PRESS", x=x, y=y, ctrl=ctrl)
    yield
    for s in np.linspace(0, 1, steps)[1:]:
        x, y = to_window(region, np.asarray(start) + s * (np.asarray(end) - np.asarray(start)))
        window.event_simulate(type="MOUSEMOVE", value="NOTHING", x=x, y=y, ctrl=ctrl)
        yield
    window.event_simulate(type="LEFTMOUSE", value="RELEASE", x=x, y=y, ctrl=ctrl)
    yield


def check(name, condition, detail=""):
    print(("PASS " if condition else "FAIL ") + name + ("" if condition else ": " + str(detail)), flush=True)
    if not condition:
        failed.append(name)


def scenario():
    obj = setup()
    yield
    window, area, region, sidebar = view3d()
    positions = mesh_io.read_mesh(obj).positions

    # --- Comb modal started from the sidebar (like the panel button), stroke along +X at y = 0.
    with bpy.context.temp_override(window=window, area=area, region=sidebar):
        bpy.ops.texsynth.comb("INVOKE_DEFAULT")
    yield
    check("comb_modal_running", obj.name in overlay.active_editors, overlay.active_editors)
    x, y = to_window(region, (0.3, -0.4, 0.0))
    window.event_simulate(type="MOUSEMOVE", value="NOTHING", x=x, y=y)
    yield
    cursor = overlay.brush_cursor
    check("brush_cursor_follows_the_mouse", cursor is not None and np.linalg.norm(cursor[0] - (0.3, -0.4, 0.0)) < 0.02
          and abs(cursor[1][2]) > 0.99 and abs(cursor[2] - 0.25) < 1e-6, cursor)
    yield from drag(window, region, (-0.7, 0.0, 0.0), (0.7, 0.0, 0.0))
    core = (np.abs(positions[:, 1]) < 0.1) & (np.abs(positions[:, 0]) < 0.5)
    errors = angle_deg(world_direction(obj)[core], (1.0, 0.0, 0.0))
    check("comb_stroke_sets_directions", core.sum() > 10 and errors.max() < 5.0, errors.max())
    far = np.abs(positions[:, 1]) > 0.8
    check("comb_field_relaxed_everywhere", np.median(angle_deg(world_direction(obj)[far], (1.0, 0.0, 0.0))) < 10.0)
    area.tag_redraw()
    yield  # let the viewport redraw after the stroke's commit invalidated the arrows
    yield
    check("overlay_batch_built_while_combing", overlay._cache.get(obj.name, (None, None))[1] is not None,
          overlay._cache.get(obj.name))
    # Ctrl-drag erases the anchors under the brush.
    yield from drag(window, region, (-0.3, 0.0, 0.0), (0.3, 0.0, 0.0), ctrl=True)
    guide = mesh_io.read_point_attribute(obj.data, authoring.GUIDE_NAME, "FLOAT_VECTOR")
    erased = (np.abs(positions[:, 1]) < 0.1) & (np.abs(positions[:, 0]) < 0.2)
    kept = (np.abs(positions[:, 1]) < 0.1) & (np.abs(positions[:, 0]) > 0.6) & (np.abs(positions[:, 0]) < 0.7)
    check("ctrl_drag_erases", not guide[erased].any() and np.all(np.any(guide[kept] != 0, axis=1)))
    x, y = to_window(region, (0.0, 0.0, 0.0))
    window.event_simulate(type="ESC", value="PRESS", x=x, y=y)
    yield
    window.event_simulate(type="ESC", value="RELEASE", x=x, y=y)
    yield
    check("comb_modal_finished", obj.name not in overlay.active_editors and overlay.brush_cursor is None,
          overlay.active_editors)

    # --- Source picked with a click after pressing the sidebar button.
    target = np.array([0.5, 0.5, 0.0])
    with bpy.context.temp_override(window=window, area=area, region=sidebar):
        bpy.ops.texsynth.singularity("INVOKE_DEFAULT", mode="SOURCE")
    yield
    x, y = to_window(region, target)
    window.event_simulate(type="MOUSEMOVE", value="NOTHING", x=x, y=y)
    yield
    window.event_simulate(type="LEFTMOUSE", value="PRESS", x=x, y=y)
    yield
    window.event_simulate(type="LEFTMOUSE", value="RELEASE", x=x, y=y)
    yield
    singular = mesh_io.read_point_attribute(obj.data, authoring.SINGULARITY_NAME, "INT")
    nearest = int(np.argmin(np.linalg.norm(positions - target, axis=1)))
    check("source_picked_at_click", singular is not None and singular[nearest] == 1 and np.count_nonzero(singular) == 1,
          None if singular is None else np.flatnonzero(singular))

    # --- Workspace tool: selectable (simulated events do not reach tool keymaps, even Blender's
    # own Annotate tool, so its drag is not simulated here).
    with bpy.context.temp_override(window=window, area=area, region=region):
        bpy.ops.wm.tool_set_by_id(name="texsynth.comb_tool")
    yield
    with bpy.context.temp_override(window=window, area=area, region=region):
        check("comb_tool_active", overlay.comb_tool_active(bpy.context))


def driver():
    steps = scenario()

    def tick():
        try:
            next(steps)
            return 0.15
        except StopIteration:
            pass
        except Exception:
            traceback.print_exc()
            failed.append("exception")
        print("GUI SUMMARY failed=%d %s" % (len(failed), " ".join(failed)), flush=True)
        bpy.ops.wm.quit_blender()
        return None
    return tick


bpy.app.timers.register(driver(), first_interval=1.0)
