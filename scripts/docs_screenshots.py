# SPDX-License-Identifier: GPL-3.0-or-later
"""Pictures for docs/user/: the TexSynth sidebar of a real Blender UI and a result, per shot.

Run by scripts/docs_screenshots.sh (one Blender per shot, under Xvfb, not in background mode):

  blender --factory-startup --enable-event-simulate blend_samples/scene.blend \\
      --python scripts/docs_screenshots.py -- OUT_DIR SHOT

SHOT is one of SHOTS below. Each shot sets the panel as an artist would (method, sample, scale),
selects the object, presses Synthesize (the operator runs blocking when called from a script),
opens the sidebar on the TexSynth tab (clicks on the tabs, as a user can), collapses the sub-panels
the page is not about (clicks on their headers), screenshots the window and crops the sidebar
(panel_<shot>.png). Then it renders the scene camera with Eevee (result_<shot>.jpg) or, for the
fields shot, crops the viewport with the field overlay (viewport_fields.jpg).
"""
import math
import os
import sys
import time
import traceback

import bpy
import mathutils
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "python_tests", "blender"))
import harness  # noqa: E402  (imports addon/ as package `texsynth`, as installed)

RENDER_SIZE = (480, 360)
RENDER_SAMPLES = 8
JPEG_QUALITY = 85

# Per shot: object(s) to synthesize on (with their own panel values, in order), the sub-panels kept open
# (by bl_idname; the others are collapsed), and what the result picture is.
SHOTS = {
    "jumpmap": dict(runs=[("Ground", dict(method="JUMPMAP", sample="moss.png", scale=2.0, seed=11)),
                          ("Suzanne", dict(method="JUMPMAP", sample="bricks.png", scale=1.2, seed=5))],
                    keep=("TEXSYNTH_PT_sample", "TEXSYNTH_PT_method"), result="render"),
    "texton": dict(runs=[("Suzanne", dict(method="TEXTON", sample="bricks.png", scale=1.2, seed=5))],
                   keep=("TEXSYNTH_PT_sample", "TEXSYNTH_PT_method"), result="render"),
    "round": dict(runs=[("Suzanne", dict(method="ROUND", sample="moss.png", scale=0.8, seed=3,
                                         bake_uv_map="UVMap", bake_size=512))],
                  keep=("TEXSYNTH_PT_method", "TEXSYNTH_PT_output"), result="render"),
    "patches": dict(runs=[("Suzanne", dict(method="PATCHES", sample="bricks.png", scale=1.2, seed=5,
                                           bake_uv_map="UVMap", bake_size=512))],
                    keep=("TEXSYNTH_PT_method", "TEXSYNTH_PT_output"), result="render"),
    "particles": dict(runs=[("Ground", dict(method="PARTICLES", sample="pebbles.png", scale=2.0, seed=1,
                                            particle_classes=3, analyse=True))],
                      keep=("TEXSYNTH_PT_method", "TEXSYNTH_PT_particles", "TEXSYNTH_PT_output"),
                      result="render"),
    "fields": dict(runs=[("Suzanne", dict(method="JUMPMAP", sample="bark.png", scale=1.0, seed=2,
                                          orientation="FIELD", preset="AXIS", source="top", show_field=True,
                                          field_arrow_density=0.3, field_arrow_length=1.5))],
                   keep=("TEXSYNTH_PT_orientation", "TEXSYNTH_PT_field"), result="viewport"),
    # Output / Bake alone (docs/user/bake.md): the Bake box of the coordinate methods.
    "bake": dict(runs=[("Suzanne", dict(method="JUMPMAP", sample="bricks.png", scale=1.2, seed=5,
                                        bake_uv_map="UVMap", bake_size=1024))],
                 keep=("TEXSYNTH_PT_output",), result=None),
    # The whole sidebar, every sub-panel open (docs/user/addon_panel.md).
    "full": dict(runs=[("Suzanne", dict(method="JUMPMAP", sample="bricks.png", scale=1.2, seed=5))],
                 keep=None, result=None),
}

argv = harness.script_args()
OUT_DIR = os.path.abspath(argv[0] if argv else os.path.join(ROOT, "out", "docs_screenshots"))
SHOT = argv[1] if len(argv) > 1 else "jumpmap"
CONFIG = SHOTS[SHOT]
os.makedirs(OUT_DIR, exist_ok=True)

texsynth = harness.load_addon()
texsynth.register()


def log(*args):
    print("DOCSHOT", SHOT, *args, flush=True)


def window_and_view():
    window = bpy.context.window_manager.windows[0]
    area = max((a for a in window.screen.areas if a.type == "VIEW_3D"), key=lambda a: a.width * a.height)
    return window, area


def region(area, kind):
    return next(r for r in area.regions if r.type == kind)


def click(window, x, y, ctrl=False):
    window.event_simulate(type="MOUSEMOVE", value="NOTHING", x=x, y=y)
    window.event_simulate(type="LEFTMOUSE", value="PRESS", x=x, y=y, ctrl=ctrl)
    window.event_simulate(type="LEFTMOUSE", value="RELEASE", x=x, y=y, ctrl=ctrl)


def screenshot(window, area):
    """The whole window as an (H, W, 3) float array, row 0 at the bottom (Blender's order)."""
    path = os.path.join(OUT_DIR, ".window_%s.png" % SHOT)
    with bpy.context.temp_override(window=window, area=area):
        bpy.ops.screen.screenshot(filepath=path)
    image = bpy.data.images.load(path)
    width, height = image.size
    pixels = np.empty(width * height * image.channels, np.float32)
    image.pixels.foreach_get(pixels)
    bpy.data.images.remove(image)
    os.remove(path)
    return pixels.reshape(height, width, -1)[:, :, :3]


def save(pixels, name, scale=1.0):
    """Saves an (H, W, 3) bottom-first array as PNG (UI) or JPEG (renders, viewport), optionally scaled down."""
    if scale != 1.0:  # a box filter: each output pixel averages its step x step block
        step = int(round(1 / scale))
        height, width = (pixels.shape[0] // step) * step, (pixels.shape[1] // step) * step
        pixels = pixels[:height, :width].reshape(height // step, step, width // step, step, 3).mean(axis=(1, 3))
    height, width = pixels.shape[:2]
    rgba = np.ones((height, width, 4), np.float32)
    rgba[:, :, :3] = pixels
    image = bpy.data.images.new(name, width, height, alpha=False)
    image.pixels.foreach_set(rgba.ravel())
    path = os.path.join(OUT_DIR, name)
    image.filepath_raw = path
    image.file_format = "JPEG" if name.endswith(".jpg") else "PNG"
    if name.endswith(".jpg"):
        scene = bpy.context.scene
        scene.render.image_settings.file_format = "JPEG"
        scene.render.image_settings.quality = JPEG_QUALITY
        scene.view_settings.view_transform = "Standard"
        scene.view_settings.look = "None"
        image.save_render(path, scene=scene)
    else:
        image.save()
    bpy.data.images.remove(image)
    log("wrote", name, width, height, os.path.getsize(path))


def header_rows(column):
    """Sub-panel headers in one pixel column of the sidebar (x inside the panels' margin), top first, as
    (top, bottom) rows from the top. A sub-panel body is drawn darker than the headers and the main panel:
    each run of the lighter colour ends with a header (HEADER rows tall); runs of several headers are
    split into HEADER-row pieces."""
    light = np.abs(column - column[5]).max(axis=1) < 0.01  # the main panel's colour at its top
    headers, y = [], 0
    while y < len(light):
        if not light[y]:
            y += 1
            continue
        end = y
        while end < len(light) and light[end]:
            end += 1
        if end < len(light):  # a run ending in a body: its last rows are a header
            # The first run is the main panel and the first header; later runs are only headers.
            count = (end - y) // HEADER if headers and (end - y) % HEADER == 0 else 1
            for k in range(count, 0, -1):
                headers.append((end - k * HEADER, end - (k - 1) * HEADER))
        y = end
    return headers


HEADER = 28  # px at UI scale 1 (measured on Blender 3.4's default theme)


def scenario():
    window, area = window_and_view()
    scene = bpy.context.scene
    props = scene.texsynth
    space = area.spaces[0]
    # The sidebar on its own background (not over the viewport): clean crops.
    bpy.context.preferences.system.use_region_overlap = False
    space.show_region_ui = True
    # A quiet viewport: no gizmos, a grey background as in the render.
    space.show_gizmo = False
    yield
    for name, values in CONFIG["runs"]:
        values = dict(values)
        obj = bpy.data.objects[name]
        harness.select_only([obj])
        props.sample_source = "FILE"
        # Relative to scene.blend (in blend_samples/), as an artist's path next to the .blend reads.
        props.sample_path = "//" + values.pop("sample")
        preset = values.pop("preset", None)
        source = values.pop("source", None)
        analyse = values.pop("analyse", False)
        for key, value in values.items():
            setattr(props, key, value)
        with bpy.context.temp_override(window=window, area=area, region=region(area, "WINDOW")):
            if preset:
                result = bpy.ops.texsynth.field_preset(preset=preset)
                log("preset", preset, result)
            if source == "top":  # a source on the top of the head: the field flows away from it
                heights = [v.co.z for v in obj.data.vertices]
                result = bpy.ops.texsynth.singularity(mode="SOURCE", vertex=heights.index(max(heights)))
                log("source", result)
            if analyse:  # Analyse Sample: the Particles panel lists the classes and shows the segmentation
                log("analyse", bpy.ops.texsynth.particle_analyse())
            start = time.perf_counter()
            result = bpy.ops.texsynth.synthesize()
            log("synthesize", name, values.get("method"), result, "%.1f s" % (time.perf_counter() - start))
        yield
    # The TexSynth tab is the sidebar's last one: click down the tab strip until below the last tab.
    sidebar = region(area, "UI")
    x = sidebar.x + sidebar.width - 10
    for offset in range(150, 262, 12):
        click(window, x, sidebar.y + sidebar.height - offset)
        yield
    area.tag_redraw()
    yield
    if CONFIG["keep"] is not None:
        # Which sub-panels are drawn, in order (registration order is the sidebar order).
        drawn = [cls.bl_idname for cls in texsynth.ui.panels.classes
                 if getattr(cls, "bl_parent_id", "") == "TEXSYNTH_PT_main"
                 and (not hasattr(cls, "poll") or cls.poll(bpy.context))]
        # A long sidebar (Particles) may not show its last headers until others are collapsed: repeat.
        collapsed = set()
        for _ in range(3):
            pixels = screenshot(window, area)[::-1]  # top first
            column = pixels[sidebar_rows(sidebar, pixels.shape[0]), sidebar.x + 8]
            headers = header_rows(column)
            log("headers", headers, "panels", drawn)
            if len(headers) > len(drawn):
                raise RuntimeError("found %d sub-panel headers, expected %d" % (len(headers), len(drawn)))
            top = pixels.shape[0] - (sidebar.y + sidebar.height)
            todo = [(header, idname) for header, idname in zip(headers, drawn)
                    if idname not in CONFIG["keep"] and idname not in collapsed]
            for (head_top, head_bottom), idname in reversed(todo):
                y_from_top = top + (head_top + head_bottom) // 2
                click(window, sidebar.x + 60, pixels.shape[0] - 1 - y_from_top)
                collapsed.add(idname)
                yield
            if len(headers) == len(drawn) and not todo:
                break
            for _ in range(3):  # the collapse animates
                area.tag_redraw()
                yield
        for _ in range(3):  # the collapse animates
            area.tag_redraw()
            yield
    if CONFIG["result"] == "viewport":
        with bpy.context.temp_override(window=window, area=area, region=region(area, "WINDOW")):
            from texsynth.fields import overlay
            bpy.ops.wm.tool_set_by_id(name=overlay.COMB_TOOL_ID)
        view = space.region_3d
        view.view_perspective = "PERSP"
        view.view_rotation = mathutils.Euler((math.radians(55), 0.0, math.radians(25))).to_quaternion()
        view.view_location = obj.matrix_world.translation
        view.view_distance = 3.8
        space.overlay.show_outline_selected = False
        space.overlay.show_extras = False
        space.overlay.show_cursor = False
        space.shading.type = "SOLID"
        space.shading.color_type = "TEXTURE"
        space.overlay.show_floor = False
        space.overlay.show_axis_x = space.overlay.show_axis_y = False
        for _ in range(3):
            area.tag_redraw()
            yield
    pixels = screenshot(window, area)
    crop = pixels[sidebar.y:sidebar.y + sidebar.height, sidebar.x:sidebar.x + sidebar.width]
    save(trim_bottom(crop), "panel_%s.png" % SHOT)
    if CONFIG["result"] == "viewport":
        view = region(area, "WINDOW")
        # The view without the sidebar (it overlaps the region on the right) and the header.
        width = sidebar.x - view.x
        crop = pixels[view.y:view.y + view.height, view.x:view.x + width]
        height = min(crop.shape[0], int(width * 0.75))
        middle = crop.shape[0] // 2
        crop = crop[middle - height // 2:middle - height // 2 + height]
        save(crop, "viewport_%s.jpg" % SHOT, scale=0.5 if width > 1000 else 1.0)
    elif CONFIG["result"] == "render":
        scene.render.resolution_x, scene.render.resolution_y = RENDER_SIZE
        scene.render.resolution_percentage = 100
        scene.eevee.taa_render_samples = RENDER_SAMPLES
        scene.render.image_settings.file_format = "JPEG"
        scene.render.image_settings.quality = JPEG_QUALITY
        path = os.path.join(OUT_DIR, "result_%s.jpg" % SHOT)
        scene.render.filepath = path
        # No metadata (file path, date, render time): the same picture gives the same bytes.
        for name in scene.render.bl_rna.properties.keys():
            if name.startswith("use_stamp"):
                setattr(scene.render, name, False)
        start = time.perf_counter()
        with bpy.context.temp_override(window=window):
            bpy.ops.render.render(write_still=True)
        log("wrote", os.path.basename(path), RENDER_SIZE, os.path.getsize(path),
            "render %.1f s" % (time.perf_counter() - start))


def sidebar_rows(sidebar, height):
    """Rows of the sidebar in a top-first window picture."""
    top = height - (sidebar.y + sidebar.height)
    return slice(top, top + sidebar.height)


def trim_bottom(crop):
    """Drops the empty rows under the last panel (bottom-first array: they are the first rows) but 6."""
    panels = crop[:, :crop.shape[1] - 30]  # left of the tab strip (drawn in another colour down to the bottom)
    background = panels[10, panels.shape[1] // 2]  # rows 0-2 are the region's border
    empty = np.abs(panels - background).max(axis=(1, 2)) < 0.01
    empty[:5] = True
    first = int(np.argmin(empty)) if not empty.all() else 0
    return crop[max(0, first - 6):]


def driver():
    steps = scenario()
    failed = []

    def tick():
        try:
            next(steps)
            return 0.4
        except StopIteration:
            pass
        except Exception:  # noqa: BLE001 - report and quit, or Blender stays open under Xvfb
            traceback.print_exc()
            failed.append(True)
            log("FAILED")
        if not failed:
            log("done")
        bpy.ops.wm.quit_blender()
        return None
    return tick


bpy.app.timers.register(driver(), first_interval=1.5)
