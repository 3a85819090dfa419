# SPDX-License-Identifier: GPL-3.0-or-later
"""Round neighbourhoods and vector-field patches as the registry sees them (core/method_spec.py): the Method
panel's section, the checks of their settings, the command line's options and the job. bpy-free and
numpy-free at import (the command line reads it before the add-on loads); the job modules load on use."""
from ..core.method_spec import MethodFamily, MethodSpec
from ..core.settings import (PATCH_BOUNDARY_RANGE, PATCH_ITERATION_RANGE, PATCH_MODES, PATCH_SIZE_RANGE,
                             PATCH_TOLERANCE_RANGE, ROUND_CANDIDATE_RANGE, ROUND_LEVEL_RANGE, ROUND_RESOLUTIONS,
                             ROUND_RING_RANGE, SURFACE_TARGETS, SettingsError, finite, is_int, max_patch_boundary)

ROUND_FIELDS = ("round_levels", "round_coarse_rings", "round_fine_rings", "round_candidates")
PATCH_OPTIONS = ("mode", "patch_size", "boundary_width", "tolerance", "iterations")


def validate_surface(settings):
    """Both methods: the target and the round-neighbourhood settings (patches share its resolution)."""
    if settings.surface_target not in SURFACE_TARGETS:
        raise SettingsError("unknown target %r (choose one of %s)" % (settings.surface_target, ", ".join(SURFACE_TARGETS)))
    if settings.round_resolution not in ROUND_RESOLUTIONS:
        raise SettingsError("unknown synthesis resolution %r (choose one of %s)"
                            % (settings.round_resolution, ", ".join(ROUND_RESOLUTIONS)))
    for name, (low, high) in zip(ROUND_FIELDS, (ROUND_LEVEL_RANGE, ROUND_RING_RANGE, ROUND_RING_RANGE,
                                                ROUND_CANDIDATE_RANGE)):
        value = getattr(settings, name)
        if not is_int(value) or not low <= value <= high:
            raise SettingsError("%s must be an integer in [%d, %d], got %r" % (name.replace("_", " "), low, high, value))


def validate_patches(settings):
    validate_surface(settings)
    if settings.patch_mode not in PATCH_MODES:
        raise SettingsError("unknown patch mode %r (choose one of %s)" % (settings.patch_mode, ", ".join(PATCH_MODES)))
    low, high = PATCH_SIZE_RANGE
    if not is_int(settings.patch_size) or not low <= settings.patch_size <= high or settings.patch_size % 4:
        raise SettingsError("patch size must be a multiple of 4 in [%d, %d] sample pixels, got %r"
                            % (low, high, settings.patch_size))
    low, high = PATCH_BOUNDARY_RANGE[0], max_patch_boundary(settings.patch_size)
    if not is_int(settings.patch_boundary) or not low <= settings.patch_boundary <= high:
        raise SettingsError("boundary width must be an integer in [%d, %d] (at most half the patch size), got %r"
                            % (low, high, settings.patch_boundary))
    low, high = PATCH_TOLERANCE_RANGE
    if not (finite(settings.patch_tolerance) and low <= settings.patch_tolerance <= high):
        raise SettingsError("tolerance must be a number in [%g, %g], got %r" % (low, high, settings.patch_tolerance))
    low, high = PATCH_ITERATION_RANGE
    if not is_int(settings.patch_iterations) or not low <= settings.patch_iterations <= high:
        raise SettingsError("iterations must be an integer in [%d, %d], got %r" % (low, high, settings.patch_iterations))


def draw_round(layout, props, context):
    column = layout.column(align=True)
    for name in ROUND_FIELDS:
        column.prop(props, name)
    _draw_resolution(layout, props)


def draw_patches(layout, props, context):
    layout.prop(props, "patch_mode", text="")
    column = layout.column(align=True)
    column.prop(props, "patch_size")
    column.prop(props, "patch_boundary")
    column.prop(props, "patch_tolerance")
    if props.patch_mode == "OPTIMISATION":
        column.prop(props, "patch_iterations")
    _draw_resolution(layout, props)


def _draw_resolution(layout, props):
    layout.label(text="Synthesis Resolution:")
    layout.prop(props, "round_resolution", text="")


def make_job(run):
    from . import synthesis
    return synthesis.Job(run.objects, run.sample, run.settings, run.bake_request, run.material_mode, run.context,
                         _cache_dir(run))


def synthesize(run):
    from . import synthesis
    return synthesis.synthesize(run.objects, run.sample, run.settings, run.bake_request, run.material_mode,
                                context=run.context, cache_dir=_cache_dir(run))


def _cache_dir(run):
    # '' would keep analysed samples in memory only: an interface's unset folder means the default one.
    from ..bridge import sources
    return run.cache_dir or sources.default_cache_dir()


def add_cli_options(parser, d):
    parser.add_argument("--target", choices=("image", "vertices"), default=None,
                        help="round, patches: colours per texel of the --bake image (default) or per vertex")
    parser.add_argument("--mode", choices=("sampling", "optimisation", "optimization"), default=None,
                        help="patches: sampling (default) pastes matched patches; optimisation refines them")
    parser.add_argument("--patch-size", type=int, default=None, help="patches: patch size in sample pixels "
                        "(multiple of 4, 8-64; default 32)")
    parser.add_argument("--boundary-width", type=int, default=None,
                        help="patches: boundary zone matched and cross-faded, in sample pixels (default 4)")
    parser.add_argument("--tolerance", type=float, default=None,
                        help="patches: candidates within this factor of the best match are equally likely (default 1.2)")
    parser.add_argument("--iterations", type=int, default=None, help="patches, optimisation: iterations (default 6)")
    parser.add_argument("--levels", type=int, default=d.round_levels, help="round: resolution levels on the surface (1-6)")
    parser.add_argument("--coarse-rings", type=int, default=d.round_coarse_rings, help="round: neighbourhood rings, coarsest level")
    parser.add_argument("--fine-rings", type=int, default=d.round_fine_rings, help="round: neighbourhood rings, finer levels")
    parser.add_argument("--candidates", type=int, default=d.round_candidates, help="round: random candidates per point (0-16)")
    parser.add_argument("--synthesis-resolution", choices=("auto", "full"), default=d.round_resolution.lower(),
                        help="round: auto reduces a sample finer than the target to its texel density first")


def check_cli_args(args, spec, d):
    """The message of the first misplaced option (None when all fit); fills the patch options' defaults."""
    if args.target is not None and not spec.colours_surface:
        return "--target is for --method %s" % " or ".join(m.cli_name for m in FAMILY.methods)
    patch_options = [name for name in PATCH_OPTIONS if getattr(args, name) is not None]
    if patch_options and spec is not PATCHES:
        return "--%s is for --method %s" % (patch_options[0].replace("_", "-"), PATCHES.cli_name)
    if args.iterations is not None and (args.mode or "sampling") == "sampling":
        return "--iterations is for --mode optimisation"
    args.mode = {"optimization": "optimisation"}.get(args.mode, args.mode or d.patch_mode.lower())
    args.patch_size = d.patch_size if args.patch_size is None else args.patch_size
    args.boundary_width = d.patch_boundary if args.boundary_width is None else args.boundary_width
    args.tolerance = d.patch_tolerance if args.tolerance is None else args.tolerance
    args.iterations = d.patch_iterations if args.iterations is None else args.iterations
    args.target = args.target or d.surface_target.lower()
    return None


def check_cli_outputs(args, spec):
    if not spec.colours_surface:
        return None
    if args.bake_material:
        return ("--bake-material is for baking jump-map or texton results; --method %s uses --material"
                % args.method)
    if args.target == "vertices" and args.bake is not None:
        return "--target vertices writes a colour attribute: drop --bake"
    return None


def settings_from_cli(args, spec, d):
    return dict(surface_target=args.target.upper(), round_levels=args.levels, round_coarse_rings=args.coarse_rings,
                round_fine_rings=args.fine_rings, round_candidates=args.candidates,
                round_resolution=args.synthesis_resolution.upper(), patch_mode=args.mode.upper(),
                patch_size=args.patch_size, patch_boundary=args.boundary_width, patch_tolerance=args.tolerance,
                patch_iterations=args.iterations)


ROUND = MethodSpec(
    "ROUND", "round", "Round Neighbourhoods",
    "Pixel-level synthesis on the surface (Chen & Dong): a colour per texel of an image through a UV map, or per "
    "vertex; no seams across UV islands",
    colours_surface=True, validate=validate_surface, draw=draw_round, make_job=make_job, synthesize=synthesize)
PATCHES = MethodSpec(
    "PATCHES", "patches", "Vector-Field Patches",
    "Whole sample patches resampled along the direction field (Chen, Liu & Dong): large, structured samples "
    "(bricks, weaves, scales) follow the field without distortion; colours per texel or per vertex",
    colours_surface=True, live_update="PREVIEW", validate=validate_patches, draw=draw_patches, make_job=make_job,
    synthesize=synthesize)
FAMILY = MethodFamily(
    "surface_colour", (ROUND, PATCHES),
    settings_fields=("surface_target", "round_resolution") + ROUND_FIELDS
    + ("patch_mode", "patch_size", "patch_boundary", "patch_tolerance", "patch_iterations"),
    add_cli_options=add_cli_options, check_cli_args=check_cli_args, check_cli_outputs=check_cli_outputs,
    settings_from_cli=settings_from_cli)
