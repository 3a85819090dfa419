# SPDX-License-Identifier: GPL-3.0-or-later
"""Screenshot of the TexSynth sidebar at Blender's default sidebar width, for the README:

  xvfb-run -a -s "-screen 0 1600x1000x24" blender --factory-startup --enable-event-simulate \\
      --python scripts/sidebar_picture.py -- OUT.png|OUT.jpg [JUMPMAP|TEXTON|ROUND]

(blend_samples/sidebar_round.jpg is made with -screen 0 1400x1500x24 and ROUND.)

Opens the sidebar, switches to the TexSynth tab (Ctrl+Wheel over the tabs, as a user can), screenshots
the window and crops the sidebar.
"""
import os
import sys

import bpy
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "python_tests", "blender"))
import harness  # noqa: E402

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
OUT = os.path.abspath(argv[0] if argv else os.path.join(ROOT, "out", "sidebar.png"))
METHOD = argv[1] if len(argv) > 1 else "ROUND"
texsynth = harness.load_addon()
texsynth.register()


def areas():
    window = bpy.context.window_manager.windows[0]
    area = next(a for a in window.screen.areas if a.type == "VIEW_3D")
    return window, area


def _texsynth_tab_open(sidebar):
    """Whether the sidebar shows TexSynth's panels (a panel's layout exists only while it is drawn)."""
    return any(getattr(panel, "bl_idname", "") == "TEXSYNTH_PT_main" for panel in getattr(sidebar, "panels", []))


def scenario():
    window, area = areas()
    props = bpy.context.scene.texsynth
    props.sample_path = os.path.join(ROOT, "blend_samples", "bricks.png")
    props.method = METHOD
    area.spaces[0].show_region_ui = True
    yield
    sidebar = next(r for r in area.regions if r.type == "UI")
    # The tabs run down the sidebar's right edge (Item, Tool, View, then add-ons): click each lower
    # position in turn until the TexSynth panel is the one drawn.
    x = sidebar.x + sidebar.width - 10
    for offset in range(150, 260, 12):
        y = sidebar.y + sidebar.height - offset
        window.event_simulate(type="MOUSEMOVE", value="NOTHING", x=x, y=y)
        window.event_simulate(type="LEFTMOUSE", value="PRESS", x=x, y=y)
        window.event_simulate(type="LEFTMOUSE", value="RELEASE", x=x, y=y)
        yield
        if bpy.types.TEXSYNTH_PT_main.is_registered and _texsynth_tab_open(sidebar):
            break
    area.tag_redraw()
    yield
    path = OUT + ".full.png"
    with bpy.context.temp_override(window=window, area=area):
        bpy.ops.screen.screenshot(filepath=path)
    yield
    image = bpy.data.images.load(path)
    width, height = image.size
    pixels = np.empty(width * height * image.channels, np.float32)
    image.pixels.foreach_get(pixels)
    pixels = pixels.reshape(height, width, image.channels)
    crop = pixels[sidebar.y:sidebar.y + sidebar.height, sidebar.x:sidebar.x + sidebar.width]
    out = bpy.data.images.new("sidebar", crop.shape[1], crop.shape[0], alpha=False)
    out.pixels.foreach_set(np.ascontiguousarray(crop).ravel())
    out.filepath_raw = OUT
    out.file_format = "JPEG" if OUT.lower().endswith((".jpg", ".jpeg")) else "PNG"
    out.save()
    os.remove(path)
    print("SIDEBAR", OUT, crop.shape[1], crop.shape[0], flush=True)


def driver():
    steps = scenario()

    def tick():
        try:
            next(steps)
            return 0.3
        except StopIteration:
            pass
        bpy.ops.wm.quit_blender()
        return None
    return tick


bpy.app.timers.register(driver(), first_interval=1.5)
