# SPDX-License-Identifier: GPL-3.0-or-later
"""TexSynth: texture synthesis on meshes without UVs (jump maps), with seam-hiding blend layers.

Light entry point: registration only. The native module is imported lazily (native.py) so enabling
the add-on never fails because of it; the panel shows why it is unavailable.
"""
bl_info = {
    "name": "TexSynth",
    "author": "TexSynth contributors",
    "version": (0, 1, 0),
    "blender": (3, 4, 0),
    "location": "3D Viewport > Sidebar > TexSynth",
    "description": "Synthesize a sample texture over meshes without UVs (per-corner UVs + blend layers)",
    "category": "Material",
    "doc_url": "",
}

import bpy  # noqa: E402

from . import compat  # noqa: E402

# Checked before anything else is imported: an older Blender gets one sentence, not an API traceback.
UNSUPPORTED = compat.unsupported_version_message(bpy.app.version)
if not UNSUPPORTED:
    from . import field_ops, operators, overlay, properties, ui  # noqa: E402
    classes = properties.classes + operators.classes + field_ops.classes + ui.classes
else:
    classes = []


def register():
    if UNSUPPORTED:
        raise RuntimeError(UNSUPPORTED)
    warning = compat.untested_version_message(bpy.app.version)
    if warning:
        print("TexSynth: " + warning)
    unregister()  # twice-safe: a half-registered previous run is cleaned first
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.Scene.texsynth = bpy.props.PointerProperty(type=properties.TexSynthSettings)
    overlay.register()
    field_ops.register_tool()


def unregister():
    if UNSUPPORTED:
        return
    field_ops.unregister_tool()
    overlay.unregister()
    if hasattr(bpy.types.Scene, "texsynth"):
        del bpy.types.Scene.texsynth
    for cls in reversed(classes):
        if getattr(cls, "is_registered", False):
            bpy.utils.unregister_class(cls)
