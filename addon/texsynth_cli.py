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
import types

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
                     epilog="--method %s keep their colours only in the scene: they need --bake, --save, --render "
                            "or --stats, and are refused (exit 2) without any of them." % " and ".join(_kept_in_scene()))
    parser.add_argument("--sample", required=True, help="sample texture image file")
    target = parser.add_mutually_exclusive_group(required=True)
    target.add_argument("--object", action="append", metavar="NAME",
                        help="mesh object in the opened scene (repeatable)")
    target.add_argument("--mesh", metavar="FILE", help=".obj, .ply or .stl file to import")
    registry = _registry()  # the methods, their options and checks (methods.py)
    parser.add_argument("--method", default=_cli_name(d.method), choices=[m.cli_name for m in registry.all_methods()],
                        help="synthesis method (default %s); %s need an output, see below"
                             % (_cli_name(d.method), " and ".join(_kept_in_scene())))
    for family in registry.FAMILIES:
        family.add_cli_options(parser, d)
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
    spec = registry.by_cli_name(args.method)
    # Every family checks its options (and fills their defaults), then the output options: the first message wins.
    messages = ([family.check_cli_args(args, spec, d) for family in registry.FAMILIES]
                + [family.check_cli_outputs(args, spec) for family in registry.FAMILIES])
    if any(messages):
        raise UsageError(next(message for message in messages if message))
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


def check_kept_output(args):
    """round and patches leave their colours in the scene only (an image or attribute): refused from the
    command line when nothing would save, bake, render or measure them. Not checked for main() called from
    Python, whose caller reads the scene (python_tests/blender/output_digest.py)."""
    if not _registry().by_cli_name(args.method).colours_surface or any((args.bake, args.save, args.render, args.stats)):
        return
    where = "--save OUT.blend" if args.target == "vertices" else "--bake IMAGE.png or --save OUT.blend"
    raise UsageError("--method %s keeps its result only in the scene and nothing would be written: add %s "
                     "(or --render OUT.png, --stats OUT.json)" % (args.method, where))


def check_bake_args(args):
    """--bake-* options: only with --bake, one object, a supported image type, sizes in range, and never
    through TexSynth's own UV map (core/bake_options.py: the same rules as the operator)."""
    options = _standalone("core.bake_options")
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


STANDALONE = "texsynth_cli_addon"


def _standalone(module):
    """An add-on module that imports without bpy and numpy (core/, the method registry) loaded before the add-on,
    under a package of its own whose __init__.py (registration, bpy) never runs."""
    if STANDALONE not in sys.modules:
        package = types.ModuleType(STANDALONE)
        package.__path__ = [os.path.dirname(os.path.abspath(__file__))]
        sys.modules[STANDALONE] = package
    return importlib.import_module(STANDALONE + "." + module)


def _registry():
    """methods.py: the methods, their options and checks (what the parser offers)."""
    return _standalone("methods")


def _cli_name(method_id):
    return _registry().get(method_id).cli_name


def _kept_in_scene():
    """The --method names whose result stays in the scene only (colours on the surface)."""
    return [m.cli_name for m in _registry().all_methods() if m.colours_surface]


def _defaults():
    """Settings() as core/settings.py defines it: every option's default is written once, there."""
    return _standalone("core.settings").Settings()


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


def settings_from_args(args, Settings, registry=None):
    """The run's Settings from parsed arguments (Settings, registry: the add-on's once it is loaded; by default
    the parser's); an option not given keeps the Settings default. ValueError for a family option it cannot read."""
    registry = registry or _registry()
    direction_attribute = args.direction_attribute or (FIELD_NAME if args.field_preset else "")
    spec, d = registry.by_cli_name(args.method), _defaults()
    family_settings = {}
    for family in registry.FAMILIES:
        family_settings.update(family.settings_from_cli(args, spec, d))
    return Settings(method=spec.id, sample_world_size=args.scale, seed=args.seed,
                    jump_rate=args.jump_rate, working_size=args.working_size, blend=not args.no_blend,
                    blend_mode=args.blend_mode.upper(),
                    allow_oversized=args.allow_oversized, blend_threshold=args.blend_threshold,
                    orientation="FIELD" if direction_attribute else "AXIS", axis=args.axis,
                    direction_attribute=direction_attribute,
                    scale_source="ATTRIBUTE" if args.scale_attribute else
                    "VERTEX_GROUP" if args.scale_group else "NONE",
                    scale_attribute=args.scale_attribute or d.scale_attribute,
                    scale_group=args.scale_group, scale_min=args.scale_range[0],
                    scale_max=args.scale_range[1], interface="CLI", **family_settings)


def main(argv, command_line=False):
    started = time.perf_counter()
    args = parse_args(argv)
    addon = load_addon()
    if addon.UNSUPPORTED:
        raise CliError(addon.UNSUPPORTED)
    from texsynth import methods, native  # registered by load_addon
    from texsynth.bridge import sources
    from texsynth.core import bake_options
    from texsynth.core.method_spec import RunRequest
    from texsynth.core.settings import Settings
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
    try:
        settings = settings_from_args(args, Settings, methods)
    except ValueError as error:
        raise CliError(str(error))
    spec = methods.get(settings.method)
    request = bake_request(args, bake_options) if args.bake else bake_options.BakeRequest(create_uv=True)
    run = RunRequest(objects, sources.Sample(path=os.path.abspath(args.sample)), settings, cache_dir=args.cache_dir,
                     material_mode=args.material.upper(), bake_request=request, scene=bpy.context.scene)
    try:
        settings.validate()
        if command_line:  # after the settings' own errors (exit 1), before any synthesis
            check_kept_output(args)
        methods.family_of(spec).prepare_cli_run(args, run)
        report = spec.synthesize(run)
    except (ValueError, RuntimeError) as error:
        raise CliError(str(error))
    if report.failures:
        raise CliError(report.summary())
    stats = report.as_json()
    if args.bake and not spec.colours_surface:  # surface colours were synthesized into the --bake image itself
        try:
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
