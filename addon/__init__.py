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

# Checked before anything else is imported: a Blender that is too old, or a Python without NumPy,
# gets one sentence in the sidebar and the console, never a traceback at enable time.
UNSUPPORTED = compat.unsupported_version_message(bpy.app.version) or compat.missing_requirement_message()
if not UNSUPPORTED:
    from .fields import overlay  # noqa: E402
    from .ui import field_operators, operators, panels, particle_operators, properties  # noqa: E402
    classes = (properties.classes + operators.classes + particle_operators.classes + field_operators.classes
               + panels.classes)
else:
    class TEXSYNTH_PT_unavailable(bpy.types.Panel):
        bl_label = "TexSynth"
        bl_space_type = "VIEW_3D"
        bl_region_type = "UI"
        bl_category = "TexSynth"

        def draw(self, context):
            column = self.layout.column(align=True)
            column.label(text="TexSynth is not available:", icon="ERROR")
            # Labels do not wrap: about 7 px per character at UI scale 1 keeps lines inside the sidebar.
            chars = max(16, int(context.region.width / (7.0 * context.preferences.system.ui_scale)) - 2)
            for line in _wrap(UNSUPPORTED, chars):
                column.label(text=line)

    def _wrap(text, width):
        lines, line = [], ""
        for word in text.split():
            if line and len(line) + 1 + len(word) > width:
                lines.append(line)
                line = word
            else:
                line = (line + " " + word).strip()
        return lines + [line]

    classes = [TEXSYNTH_PT_unavailable]


def register():
    if UNSUPPORTED:
        print("TexSynth: " + UNSUPPORTED)
        if not getattr(classes[0], "is_registered", False):
            bpy.utils.register_class(classes[0])
        return
    warning = compat.untested_version_message(bpy.app.version)
    if warning:
        print("TexSynth: " + warning)
    # A package for another Python or platform: said once in the console too, not only in the sidebar.
    from . import native
    mismatch = native.diagnose()
    if mismatch:
        print("TexSynth: " + mismatch)
    unregister()  # twice-safe: a half-registered previous run is cleaned first
    for cls in classes:
        bpy.utils.register_class(cls)
    bpy.types.Scene.texsynth = bpy.props.PointerProperty(type=properties.TexSynthSettings)
    overlay.register()
    field_operators.register_tool()
    particle_operators.register_header()


def unregister():
    if UNSUPPORTED:
        if getattr(classes[0], "is_registered", False):
            bpy.utils.unregister_class(classes[0])
        return
    particle_operators.unregister_header()
    field_operators.unregister_tool()
    overlay.unregister()
    if hasattr(bpy.types.Scene, "texsynth"):
        del bpy.types.Scene.texsynth
    for cls in reversed(classes):
        if getattr(cls, "is_registered", False):
            bpy.utils.unregister_class(cls)
