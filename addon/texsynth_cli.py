# SPDX-License-Identifier: GPL-3.0-or-later
"""Headless TexSynth for pipelines:

  blender -b [scene.blend] --python-exit-code 1 --python addon/texsynth_cli.py -- \\
      --sample IMAGE (--object NAME | --mesh FILE.obj|.ply|.stl) [--method jumpmap|texton|round|patches] [--scale S]
      [--seed N] [--no-blend] [--blend-mode auto|histogram|variance|linear] [--blend-threshold PHI]
      [--direction-attribute NAME | --field-preset axis|curvature|smooth] [--axis X|Y|Z|-X|-Y|-Z|x,y,z]
      [--scale-attribute NAME | --scale-group NAME [--scale-range LO HI]] [--save OUT.blend]
      [--render OUT.png] [--resolution W H] [--stats OUT.json]
      [--bake IMAGE.png [--bake-uv NAME|auto] [--bake-size N] [--bake-margin PX] [--bake-material]]
      [--target image|vertices] [--levels N] [--coarse-rings K] [--fine-rings K] [--candidates N]
      [--synthesis-resolution auto|full]
      [--mode sampling|optimisation] [--patch-size N] [--boundary-width N] [--tolerance T] [--iterations N]
      [--classes K] [--blur SIGMA] [--min-area PX] [--background-class C] [--merges a>b,...] [--class-order c,...]
      [--labels IMAGE] [--write-labels PNG] [--particle-output decals|instances|both] [--instances COLLECTION] [--size-jitter J]
      [--density NAME] [--probability NAME] [--size NAME] [--background jumpmap|texton|none]

--method round and --method patches synthesize a colour per texel of the --bake image through --bake-uv
(default: the first UV map, or a new Smart UV Project map), or per vertex with --target vertices
(attribute TexSynth_Colour). patches: vector-field patches (Chen, Liu & Dong), --mode sampling (default,
fast) or optimisation (refines the sampled result). particles: texture particles (Dischler et al.): the sample's
elements placed whole as decal objects per class and/or points instancing --instances (a collection of the
opened .blend, or "example" for the thorn collection of blend_samples/particle_instances.py), over the filled
background synthesized by --background; --density/--probability/--size name a face attribute or vertex group;
--bake bakes the background and composites the decals over it.

--method round and patches keep their colours only in the scene, so from the command line they need somewhere
to keep or show them: --bake, --save, --render or --stats (timings only); without any they are refused
(exit 2) before anything is synthesized.

--mesh without a .blend replaces Blender's factory Cube, Camera and Light by a camera framing the mesh and a sun.

Exit 0 on success; bad arguments or inputs print one line "texsynth_cli: error: ..." and exit 2
(arguments) or 1 (inputs, synthesis failures).
"""
import argparse
import importlib.util
import json
import math
import os
import sys
import time

import bpy

PROG = "texsynth_cli"


class CliError(Exception):
    """Bad input or a failed run: exit code 1."""
    exit_code = 1


class UsageError(CliError):
    """Bad command-line arguments: exit code 2."""
    exit_code = 2


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        raise UsageError(message)


def parse_args(argv):
    d = _defaults()
    parser = _Parser(prog=PROG, description="TexSynth: synthesize a sample texture on a mesh, headless.",
                     epilog="--method round and patches keep their colours only in the scene: they need --bake, "
                            "--save, --render or --stats, and are refused (exit 2) without any of them.")
    parser.add_argument("--sample", required=True, help="sample texture image file")
    target = parser.add_mutually_exclusive_group(required=True)
    target.add_argument("--object", action="append", metavar="NAME",
                        help="mesh object in the opened scene (repeatable)")
    target.add_argument("--mesh", metavar="FILE", help=".obj, .ply or .stl file to import")
    parser.add_argument("--method", default="jumpmap", choices=["jumpmap", "texton", "round", "patches", "particles"],
                        help="synthesis method (default jumpmap); round and patches need an output, see below")
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
    particles = parser.add_argument_group("particles")
    particles.add_argument("--classes", type=int, default=None, help="particles: colour classes (2-12, default 4)")
    particles.add_argument("--blur", type=float, default=None, help="particles: segmentation blur in pixels (1)")
    particles.add_argument("--min-area", type=int, default=None, help="particles: smallest particle in pixels")
    particles.add_argument("--background-class", type=int, default=None, help="particles: background class id")
    particles.add_argument("--merges", default=None, metavar="a>b,...", help="particles: class merges")
    particles.add_argument("--class-order", default=None, metavar="c,...", help="particles: classes to place, in order")
    particles.add_argument("--labels", default=None, metavar="IMAGE",
                           help="particles: label image of the sample's size, one colour per class")
    particles.add_argument("--write-labels", default=None, metavar="PNG",
                           help="particles: also write the segmentation as a label image (one flat colour per "
                                "class) to repaint and give back as --labels")
    particles.add_argument("--particle-output", choices=("decals", "instances", "both"), default=None)
    particles.add_argument("--instances", default=None, metavar="COLLECTION",
                           help="particles: collection instanced per class ('example': the thorn collection)")
    particles.add_argument("--size-jitter", type=float, default=None, help="particles: size variation 0-0.9")
    for name in ("density", "probability", "size"):
        particles.add_argument("--" + name, default=None, metavar="NAME",
                               help="particles: face attribute or vertex group giving the %s per face" % name)
    particles.add_argument("--background", choices=("jumpmap", "texton", "none"), default=None,
                           help="particles: how the filled background is synthesized (default jumpmap)")
    parser.add_argument("--levels", type=int, default=d.round_levels, help="round: resolution levels on the surface (1-6)")
    parser.add_argument("--coarse-rings", type=int, default=d.round_coarse_rings, help="round: neighbourhood rings, coarsest level")
    parser.add_argument("--fine-rings", type=int, default=d.round_fine_rings, help="round: neighbourhood rings, finer levels")
    parser.add_argument("--candidates", type=int, default=d.round_candidates, help="round: random candidates per point (0-16)")
    parser.add_argument("--synthesis-resolution", choices=("auto", "full"), default="auto",
                        help="round: auto reduces a sample finer than the target to its texel density first")
    parser.add_argument("--scale", type=float, default=d.sample_world_size,
                        help="world size of the sample's width, in world units (default 1)")
    parser.add_argument("--seed", type=int, default=d.seed)
    parser.add_argument("--jump-rate", type=float, default=d.jump_rate)
    parser.add_argument("--working-size", type=int, default=d.working_size,
                        help="jumpmap/texton: longest side the sample is analysed at (0 = its own resolution)")
    parser.add_argument("--no-blend", action="store_true", help="only the base UV layer, no blend sets")
    parser.add_argument("--blend-mode", choices=("auto", "histogram", "variance", "linear"), default="auto",
                        help="how the shader cross-fades the blend sets. auto (default): jumpmap takes histogram, "
                             "or variance when the histogram transform keeps under 97 %% of the sample's detail or "
                             "cannot serve the sample; texton takes linear for periodic samples (periodicity >= 0.5), "
                             "variance for stochastic ones")
    parser.add_argument("--blend-threshold", type=float, default=d.blend_threshold,
                        help="texton method: blend only edges whose blending metric from the scene camera "
                             "exceeds this (0 = every edge)")
    parser.add_argument("--allow-oversized", action="store_true",
                        help="map faces larger than the sample at this scale instead of refusing them")
    parser.add_argument("--direction-attribute", metavar="NAME", default="",
                        help="orient the texture along this vertex vector attribute (e.g. TexSynth_Direction)")
    parser.add_argument("--axis", default=None, metavar="X|Y|Z|-X|-Y|-Z|x,y,z",
                        help="the panel's Axis: texture 'up' follows this global axis projected on the surface "
                             "(default Z); with --field-preset, the field's fallback direction")
    parser.add_argument("--field-preset", choices=("axis", "curvature", "smooth"), default=None,
                        help="the add-on's Field Preset: writes the direction field TexSynth_Direction (axis: "
                             "--axis projected; curvature: along the least curvature; smooth: the mesh's "
                             "field relaxed, 10 iterations) and orients the texture along it")
    scale = parser.add_mutually_exclusive_group()
    scale.add_argument("--scale-attribute", metavar="NAME", default="",
                       help="per-vertex density multiplier from this float vertex attribute (e.g. TexSynth_Scale)")
    scale.add_argument("--scale-group", metavar="NAME", default="",
                       help="per-vertex density multiplier from this vertex group's weights (see --scale-range)")
    parser.add_argument("--scale-range", type=float, nargs=2, metavar=("LO", "HI"), default=(d.scale_min, d.scale_max),
                        help="density multiplier at weight 0 and 1 for --scale-group (default 0.5 2)")
    parser.add_argument("--material", default="new", choices=["new", "insert", "none"])
    parser.add_argument("--cache-dir", default="", help="preprocessing cache folder (default: Blender's)")
    parser.add_argument("--save", metavar="OUT.blend")
    parser.add_argument("--render", metavar="OUT.png", help="render the scene with Eevee")
    parser.add_argument("--resolution", type=int, nargs=2, metavar=("W", "H"))
    parser.add_argument("--stats", metavar="OUT.json")
    parser.add_argument("--bake", metavar="IMAGE.png",
                        help="after synthesis, bake the object's result into this image file (.png, .exr, ...)")
    parser.add_argument("--bake-uv", metavar="NAME", default=None,
                        help="UV map to bake through (not TexSynth); auto (default): the first other UV map, "
                             "or a new one made with Smart UV Project")
    parser.add_argument("--bake-size", type=int, default=None, metavar="N", help="baked image size (default 1024)")
    parser.add_argument("--bake-margin", type=int, default=None, metavar="PX", help="bake margin (default 16 px)")
    parser.add_argument("--bake-material", action="store_true",
                        help="also create and assign 'TexSynth Baked: <object>' using only the baked image")
    args = parser.parse_args(with_axis_values(argv))
    args.axis = parse_axis(args.axis)
    if args.field_preset and args.direction_attribute not in ("", FIELD_NAME):
        raise UsageError("--field-preset writes %s and orients along it: drop --direction-attribute %s"
                         % (FIELD_NAME, args.direction_attribute))
    if not math.isfinite(args.scale) or args.scale <= 0:
        raise UsageError("--scale must be a positive number of world units, got %s" % args.scale)
    if not all(math.isfinite(v) and v > 0 for v in args.scale_range):
        raise UsageError("--scale-range must be two positive numbers, got %s" % list(args.scale_range))
    if args.resolution and not all(4 <= v <= 16384 for v in args.resolution):
        raise UsageError("--resolution must be two integers in [4, 16384], got %s" % args.resolution)
    surface = args.method in ("round", "patches")
    if args.target is not None and not surface:
        raise UsageError("--target is for --method round or patches")
    patch_options = [name for name in ("mode", "patch_size", "boundary_width", "tolerance", "iterations")
                     if getattr(args, name) is not None]
    if patch_options and args.method != "patches":
        raise UsageError("--%s is for --method patches" % patch_options[0].replace("_", "-"))
    if args.iterations is not None and (args.mode or "sampling") == "sampling":
        raise UsageError("--iterations is for --mode optimisation")
    args.mode = {"optimization": "optimisation"}.get(args.mode, args.mode or d.patch_mode.lower())
    args.patch_size = d.patch_size if args.patch_size is None else args.patch_size
    args.boundary_width = d.patch_boundary if args.boundary_width is None else args.boundary_width
    args.tolerance = d.patch_tolerance if args.tolerance is None else args.tolerance
    args.iterations = d.patch_iterations if args.iterations is None else args.iterations
    args.target = args.target or d.surface_target.lower()
    check_particle_args(args)
    if surface and args.bake_material:
        raise UsageError("--bake-material is for baking jump-map or texton results; --method %s uses --material"
                         % args.method)
    if surface and args.target == "vertices" and args.bake is not None:
        raise UsageError("--target vertices writes a colour attribute: drop --bake")
    check_bake_args(args)
    for option in ("save", "render", "stats", "bake"):
        path = getattr(args, option)
        if path is not None:
            folder = os.path.dirname(os.path.abspath(path))
            if not os.path.isdir(folder):
                raise UsageError("--%s folder does not exist: %s" % (option, folder))
    return args


AXES = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "Z": (0.0, 0.0, 1.0)}
FIELD_NAME = "TexSynth_Direction"  # fields/authoring.DIRECTION_NAME, what Field Preset writes


def with_axis_values(argv):
    """argparse takes `--axis -X` for two options: joined into `--axis=-X`."""
    argv, joined = list(argv), []
    while argv:
        item = argv.pop(0)
        if item == "--axis" and argv and argv[0].startswith("-") and not argv[0].startswith("--"):
            item = "--axis=" + argv.pop(0)
        joined.append(item)
    return joined


def parse_axis(text):
    """--axis: a signed axis name or three numbers, as the panel's Axis vector (default Z)."""
    if text is None:
        return AXES["Z"]
    name = text.strip().upper()
    if name.lstrip("+-") in AXES and len(name) <= 2:
        return tuple(-c if name.startswith("-") else c for c in AXES[name.lstrip("+-")])
    try:
        vector = tuple(float(value) for value in text.split(","))
    except ValueError:
        vector = ()
    if len(vector) != 3 or not all(math.isfinite(v) for v in vector) or not any(vector):
        raise UsageError("--axis must be X, Y, Z, -X, -Y, -Z or three numbers x,y,z not all 0, got %r" % text)
    return vector


PARTICLE_OPTIONS = ("classes", "blur", "min_area", "background_class", "merges", "class_order", "labels",
                    "write_labels", "particle_output", "instances", "size_jitter", "density", "probability", "size", "background")


def check_kept_output(args):
    """round and patches leave their colours in the scene only (an image or attribute): refused from the
    command line when nothing would save, bake, render or measure them. Not checked for main() called from
    Python, whose caller reads the scene (python_tests/blender/output_digest.py)."""
    if args.method not in ("round", "patches") or any((args.bake, args.save, args.render, args.stats)):
        return
    where = "--save OUT.blend" if args.target == "vertices" else "--bake IMAGE.png or --save OUT.blend"
    raise UsageError("--method %s keeps its result only in the scene and nothing would be written: add %s "
                     "(or --render OUT.png, --stats OUT.json)" % (args.method, where))


def check_particle_args(args):
    """Particle options only with --method particles; instances need a collection; defaults filled in."""
    given = [name for name in PARTICLE_OPTIONS if getattr(args, name) is not None]
    if given and args.method != "particles":
        raise UsageError("--%s is for --method particles" % given[0].replace("_", "-"))
    args.particle_output = args.particle_output or _defaults().particle_output.lower()
    if args.particle_output != "decals" and not args.instances:
        raise UsageError("--particle-output %s needs --instances COLLECTION" % args.particle_output)
    if args.method == "particles" and args.bake is not None and args.background == "none":
        raise UsageError("--bake composites the particles over their background: drop --background none")


def particle_settings(args):
    from texsynth.particles import core
    if args.method != "particles":
        return {}
    try:
        d = _defaults()
        return dict(particle_classes=d.particle_classes if args.classes is None else args.classes,
                    particle_blur=d.particle_blur if args.blur is None else args.blur,
                    particle_min_area=d.particle_min_area if args.min_area is None else args.min_area,
                    particle_background_class=(d.particle_background_class if args.background_class is None
                                               else args.background_class),
                    particle_merges=core.parse_merges(args.merges or ""),
                    particle_class_order=core.parse_class_list(args.class_order or ""),
                    particle_output=args.particle_output.upper(), particle_collection=args.instances or "",
                    particle_size_jitter=d.particle_size_jitter if args.size_jitter is None else args.size_jitter,
                    particle_density_source=args.density or "",
                    particle_probability_source=args.probability or "", particle_size_source=args.size or "",
                    particle_background=(args.background or d.particle_background.lower()).upper())
    except ValueError as error:
        raise CliError(str(error))


def check_bake_args(args):
    """--bake-* options: only with --bake, one object, a supported image type, sizes in range, and never
    through TexSynth's own UV map (core/bake_options.py: the same rules as the operator)."""
    options = _standalone("bake_options")
    extra = [name for name in ("bake_uv", "bake_size", "bake_margin") if getattr(args, name) is not None]
    if args.bake_material:
        extra.append("bake_material")
    if args.bake is None:
        if extra:
            raise UsageError("--%s needs --bake IMAGE" % extra[0].replace("_", "-"))
        return
    if args.object is not None and len(args.object) > 1:
        raise UsageError("--bake bakes one object, got %d --object" % len(args.object))
    extension = os.path.splitext(args.bake)[1].lower()
    if extension not in options.FORMATS:
        raise UsageError("--bake needs an image file name ending in %s, got %s"
                         % (", ".join(sorted(options.FORMATS)), args.bake))
    args.bake_uv = options.AUTO_UV if args.bake_uv is None else args.bake_uv
    args.bake_size = options.DEFAULT_SIZE if args.bake_size is None else args.bake_size
    args.bake_margin = options.DEFAULT_MARGIN if args.bake_margin is None else args.bake_margin
    try:
        bake_request(args, options).validate()
    except options.BakeError as error:
        raise UsageError(str(error))


def bake_request(args, options):
    return options.BakeRequest(target=os.path.abspath(args.bake), uv_map=args.bake_uv, size=args.bake_size,
                               margin=args.bake_margin, create_uv=args.bake_uv == options.AUTO_UV,
                               material="ASSIGN" if args.bake_material else "NONE")


def _standalone(module):
    """core/<module>.py (bpy-free, no relative imports) loaded on its own, before the add-on."""
    name = "texsynth_cli_" + module
    if name not in sys.modules:
        path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "core", module + ".py")
        spec = importlib.util.spec_from_file_location(name, path)
        module_object = importlib.util.module_from_spec(spec)
        sys.modules[name] = module_object
        spec.loader.exec_module(module_object)
    return sys.modules[name]


def _defaults():
    """Settings() as core/settings.py defines it: every option's default is written once, there."""
    return _standalone("settings").Settings()


def load_addon():
    """The add-on package this script belongs to, imported as `texsynth` (not registered)."""
    here = os.path.dirname(os.path.abspath(__file__))
    module = sys.modules.get("texsynth")
    if module is not None and os.path.dirname(os.path.abspath(module.__file__)) == here:
        return module
    spec = importlib.util.spec_from_file_location("texsynth", os.path.join(here, "__init__.py"),
                                                  submodule_search_locations=[here])
    module = importlib.util.module_from_spec(spec)
    sys.modules["texsynth"] = module
    spec.loader.exec_module(module)
    return module


def settings_from_args(args, Settings):
    """The run's Settings from parsed arguments (Settings: the add-on's class, once it is loaded); an option not
    given keeps the Settings default."""
    direction_attribute = args.direction_attribute or (FIELD_NAME if args.field_preset else "")
    return Settings(method=args.method.upper(), sample_world_size=args.scale, seed=args.seed,
                    jump_rate=args.jump_rate, working_size=args.working_size, blend=not args.no_blend,
                    blend_mode=args.blend_mode.upper(),
                    allow_oversized=args.allow_oversized, blend_threshold=args.blend_threshold,
                    orientation="FIELD" if direction_attribute else "AXIS", axis=args.axis,
                    direction_attribute=direction_attribute,
                    scale_source="ATTRIBUTE" if args.scale_attribute else
                    "VERTEX_GROUP" if args.scale_group else "NONE",
                    scale_attribute=args.scale_attribute or _defaults().scale_attribute,
                    scale_group=args.scale_group, scale_min=args.scale_range[0],
                    scale_max=args.scale_range[1], surface_target=args.target.upper(),
                    round_levels=args.levels, round_coarse_rings=args.coarse_rings,
                    round_fine_rings=args.fine_rings, round_candidates=args.candidates,
                    round_resolution=args.synthesis_resolution.upper(),
                    patch_mode=args.mode.upper(), patch_size=args.patch_size,
                    patch_boundary=args.boundary_width, patch_tolerance=args.tolerance,
                    patch_iterations=args.iterations, interface="CLI", **particle_settings(args))


def main(argv, command_line=False):
    started = time.perf_counter()
    args = parse_args(argv)
    addon = load_addon()
    if addon.UNSUPPORTED:
        raise CliError(addon.UNSUPPORTED)
    from texsynth import native  # registered by load_addon
    from texsynth.bridge import sources
    from texsynth.core.settings import SURFACE_METHODS, Settings
    from texsynth.uv_methods import synthesis
    if native.get() is None:
        raise CliError(native.reason())
    if not os.path.isfile(args.sample):
        raise CliError("sample image not found: %s" % args.sample)
    from texsynth.cli import scene as cli_scene
    try:
        objects = cli_scene.find_objects(args)
    except cli_scene.SceneError as error:
        raise CliError(str(error)) from None
    if args.field_preset:
        try:
            cli_scene.apply_field_preset(args, objects)
        except cli_scene.SceneError as error:
            raise CliError(str(error)) from None
    settings = settings_from_args(args, Settings)
    sample = sources.Sample(path=os.path.abspath(args.sample))
    surface = settings.method in SURFACE_METHODS
    try:
        settings.validate()
        if command_line:  # after the settings' own errors (exit 1), before any synthesis
            check_kept_output(args)
        if settings.method == "PARTICLES":
            report = cli_scene.run_particles(args, objects, sample, settings)
        elif surface:
            from texsynth.core import bake_options as options
            from texsynth.surface_colour import synthesis as surface_synthesis
            request = bake_request(args, options) if args.bake else options.BakeRequest(create_uv=True)
            report = surface_synthesis.synthesize(objects, sample, settings, request, args.material.upper(),
                                                  cache_dir=args.cache_dir or sources.default_cache_dir())
        else:
            report = synthesis.synthesize(objects, sample, settings, args.cache_dir or None, args.material.upper())
    except (ValueError, RuntimeError) as error:
        raise CliError(str(error))
    if report.failures:
        raise CliError(report.summary())
    stats = report.as_json()
    if args.bake and not surface:
        try:
            from texsynth.core import bake_options
            print("%s: %s" % (PROG, cli_scene.run_bake(objects, bake_request(args, bake_options), stats)))
        except cli_scene.SceneError as error:
            raise CliError(str(error)) from None
    if args.save:
        bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath(args.save), copy=True)
    if args.render:
        render_start = time.perf_counter()
        try:
            cli_scene.render(bpy.context.scene, objects, args.render, args.resolution)
        except cli_scene.SceneError as error:
            raise CliError(str(error)) from None
        stats["seconds"]["render"] = time.perf_counter() - render_start
    stats["seconds"]["cli_total"] = time.perf_counter() - started
    if args.stats:
        with open(args.stats, "w") as handle:
            json.dump(stats, handle, indent=2, sort_keys=True)
    print("%s: %s" % (PROG, report.summary()))
    del addon


def run():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    try:
        main(argv, command_line=True)
    except CliError as error:
        print("%s: error: %s" % (PROG, " ".join(str(error).split())), file=sys.stderr, flush=True)
        sys.exit(error.exit_code)


if __name__ == "__main__":
    run()
