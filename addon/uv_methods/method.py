# SPDX-License-Identifier: GPL-3.0-or-later
"""Jump maps and texton strings as the registry sees them (core/method_spec.py): the Method panel's section
and the job. Their settings (jump rate, analysis size, blending) are the shared ones of core/settings.py,
checked there, and their command-line options are the CLI's own. bpy-free and numpy-free at import."""
from ..core.method_spec import MethodFamily, MethodSpec


def _draw_analysis(layout, props):
    column = layout.column(align=True)
    column.prop(props, "working_size")
    column.prop(props, "neighbourhood")


def _draw_blending(layout, props, context, threshold):
    layout.prop(props, "blend")
    if props.blend:
        layout.label(text="Blend Mode:")
        layout.prop(props, "blend_mode", text="")
    if threshold and props.blend:
        layout.prop(props, "blend_threshold")
        if props.blend_threshold > 0.0 and context.scene.camera is None:
            layout.label(text="Needs a scene camera", icon="ERROR")
    layout.prop(props, "allow_oversized")


def draw_jumpmap(layout, props, context):
    layout.prop(props, "jump_rate")
    _draw_analysis(layout, props)
    _draw_blending(layout, props, context, threshold=False)


def draw_texton(layout, props, context):
    _draw_analysis(layout, props)
    _draw_blending(layout, props, context, threshold=True)  # the texton metric Φ needs a camera


def make_job(run):
    from . import synthesis
    return synthesis.Job(run.objects, run.sample, run.settings, run.cache_dir, run.material_mode, run.scene)


def synthesize(run):
    from . import synthesis
    return synthesis.synthesize(run.objects, run.sample, run.settings, run.cache_dir or None, run.material_mode)


# Blend Mode Auto, what measured best (README, Blending): the jump map blends up to three unrelated patches
# everywhere and keeps its contrast only with HISTOGRAM; texton patches blend in narrow zones with neighbours
# the search matched, where LINEAR keeps detail (1.028 of tiling) and is cheaper.
JUMPMAP = MethodSpec("JUMPMAP", "jumpmap", "Jump Map", "Jump-map vertex walk (Zelinka & Garland)",
                     auto_blend_mode="HISTOGRAM", writes_uv=True, live_update="UV", live_from_memory=True,
                     draw=draw_jumpmap, make_job=make_job, synthesize=synthesize)
TEXTON = MethodSpec("TEXTON", "texton", "Texton Strings",
                    "Texton-string patch matching per face (Magda & Kriegman); better on structured samples",
                    auto_blend_mode="LINEAR", writes_uv=True, live_update="UV", draw=draw_texton, make_job=make_job, synthesize=synthesize)
FAMILY = MethodFamily("uv_methods", (JUMPMAP, TEXTON),
                      settings_fields=("jump_rate", "blend", "blend_mode", "blend_threshold", "neighbourhood",
                                       "working_size", "tileable", "allow_oversized"))
