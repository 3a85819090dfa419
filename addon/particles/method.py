# SPDX-License-Identifier: GPL-3.0-or-later
"""Texture particles as the registry sees them (core/method_spec.py): the Method panel's section, the checks
of their settings, the command line's options and the job. bpy-free and numpy-free at import (the command
line reads it before the add-on loads); what needs Blender or numpy loads on use."""
import os
import sys

from ..core.method_spec import MethodFamily, MethodSpec
from ..core.settings import (PARTICLE_BACKGROUNDS, PARTICLE_CLASS_RANGE, PARTICLE_MAX_BLUR, PARTICLE_MAX_JITTER,
                             PARTICLE_OUTPUTS, PARTICLE_TOUCHING, SettingsError, finite, is_int)

CLI_OPTIONS = ("classes", "blur", "min_area", "touching", "background_class", "merges", "class_order", "labels",
               "write_labels", "particle_output", "instances", "size_jitter", "density", "probability", "size",
               "background")
# A clone's root (addon/particles/ is two folders down): --instances example reads blend_samples/ there.
REPOSITORY = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def validate(settings):
    low, high = PARTICLE_CLASS_RANGE
    if not is_int(settings.particle_classes) or not low <= settings.particle_classes <= high:
        raise SettingsError("particle classes must be an integer in [%d, %d], got %r"
                            % (low, high, settings.particle_classes))
    if not (finite(settings.particle_blur) and 0.0 <= settings.particle_blur <= PARTICLE_MAX_BLUR):
        raise SettingsError("segmentation blur must be a number in [0, %g] pixels, got %r"
                            % (PARTICLE_MAX_BLUR, settings.particle_blur))
    if not is_int(settings.particle_min_area) or settings.particle_min_area < 0:
        raise SettingsError("minimum particle area must be an integer >= 0 pixels (0 = automatic), got %r"
                            % (settings.particle_min_area,))
    if not isinstance(settings.particle_touching, bool) and settings.particle_touching not in PARTICLE_TOUCHING:
        raise SettingsError("touching elements must be one of %s (or True / False), got %r"
                            % (", ".join(PARTICLE_TOUCHING), settings.particle_touching))
    if not is_int(settings.particle_background_class) or settings.particle_background_class < -1:
        raise SettingsError("background class must be a class id or -1 (largest class), got %r"
                            % (settings.particle_background_class,))
    for pair in settings.particle_merges:
        if (len(pair) != 2 or not all(is_int(c) and c >= 0 for c in pair) or pair[0] == pair[1]):
            raise SettingsError("a class merge must be two different class ids, got %r" % (pair,))
    order = list(settings.particle_class_order)
    if not all(is_int(c) and c >= 0 for c in order) or len(set(order)) != len(order):
        raise SettingsError("class order must list distinct class ids, got %r" % (tuple(order),))
    if settings.particle_output not in PARTICLE_OUTPUTS:
        raise SettingsError("unknown particle output %r (choose one of %s)"
                            % (settings.particle_output, ", ".join(PARTICLE_OUTPUTS)))
    if settings.particle_output != "DECALS" and not settings.particle_collection:
        raise SettingsError("particle output %s needs an instance collection (the objects placed per class)"
                            % settings.particle_output)
    if not (finite(settings.particle_size_jitter) and 0.0 <= settings.particle_size_jitter <= PARTICLE_MAX_JITTER):
        raise SettingsError("size jitter must be a number in [0, %g], got %r"
                            % (PARTICLE_MAX_JITTER, settings.particle_size_jitter))
    if settings.particle_background not in PARTICLE_BACKGROUNDS:
        raise SettingsError("unknown particle background %r (choose one of %s)"
                            % (settings.particle_background, ", ".join(PARTICLE_BACKGROUNDS)))


def draw(layout, props, context):
    column = layout.column(align=True)
    column.prop(props, "particle_classes")
    column.prop(props, "particle_blur")
    column.prop(props, "particle_min_area")
    layout.label(text="Touching Elements:")
    layout.row(align=True).prop(props, "particle_touching", expand=True)
    layout.label(text="Label Image (optional):")
    layout.template_ID(props, "particle_label_image", open="image.open")
    layout.operator("texsynth.particle_analyse", icon="VIEWZOOM")


def panel_settings(props):
    """The Texture Particles fields of Settings, parsed only for this method (a typo in the merges never
    blocks another method)."""
    from . import core
    return dict(particle_classes=int(props.particle_classes), particle_blur=float(props.particle_blur),
                particle_min_area=int(props.particle_min_area), particle_touching=props.particle_touching,
                particle_background_class=int(props.particle_background_class),
                particle_merges=core.parse_merges(props.particle_merges),
                particle_class_order=core.parse_class_list(props.particle_class_order),
                particle_output=props.particle_output,
                particle_collection=props.particle_collection.name if props.particle_collection else "",
                particle_size_jitter=float(props.particle_size_jitter),
                particle_density_source=props.particle_density_source.strip(),
                particle_probability_source=props.particle_probability_source.strip(),
                particle_size_source=props.particle_size_source.strip(),
                particle_background=props.particle_background)


def make_job(run):
    from . import synthesis
    return synthesis.Job(run.objects, run.sample, run.settings, run.cache_dir, run.label_pixels, run.only_class,
                         run.material_mode, run.scene)


def synthesize(run):
    from . import synthesis
    return synthesis.synthesize(run.objects, run.sample, run.settings, run.cache_dir, run.label_pixels,
                                material_mode=run.material_mode, scene_=run.scene)


def add_cli_options(parser, d):
    particles = parser.add_argument_group("particles")
    particles.add_argument("--classes", type=int, default=None, help="particles: colour classes (2-12, default 4)")
    particles.add_argument("--blur", type=float, default=None, help="particles: segmentation blur in pixels (1)")
    particles.add_argument("--min-area", type=int, default=None, help="particles: smallest particle in pixels")
    particles.add_argument("--touching", nargs="?", const="on", choices=("auto", "on", "off"), default=None,
                           help="particles: split elements that touch (gravel, cobbles) along the narrow necks "
                                "between them: auto (the default) where one region spans a fifth of the sample or "
                                "elements come out in pieces, "
                                "on (--touching alone) always, off never")
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


def check_cli_args(args, spec, d):
    """Particle options only with --method particles; instances need a collection; defaults filled in."""
    given = [name for name in CLI_OPTIONS if getattr(args, name) is not None]
    if given and spec is not PARTICLES:
        return "--%s is for --method %s" % (given[0].replace("_", "-"), PARTICLES.cli_name)
    args.particle_output = args.particle_output or d.particle_output.lower()
    if args.particle_output != "decals" and not args.instances:
        return "--particle-output %s needs --instances COLLECTION" % args.particle_output
    if spec is PARTICLES and args.bake is not None and args.background == "none":
        return "--bake composites the particles over their background: drop --background none"
    return None


def settings_from_cli(args, spec, d):
    """Raises ValueError for unreadable --merges / --class-order."""
    from . import core
    if spec is not PARTICLES:
        return {}
    return dict(particle_classes=d.particle_classes if args.classes is None else args.classes,
                particle_blur=d.particle_blur if args.blur is None else args.blur,
                particle_min_area=d.particle_min_area if args.min_area is None else args.min_area,
                particle_touching=d.particle_touching if args.touching is None else args.touching.upper(),
                particle_background_class=(d.particle_background_class if args.background_class is None
                                           else args.background_class),
                particle_merges=core.parse_merges(args.merges or ""),
                particle_class_order=core.parse_class_list(args.class_order or ""),
                particle_output=args.particle_output.upper(), particle_collection=args.instances or "",
                particle_size_jitter=d.particle_size_jitter if args.size_jitter is None else args.size_jitter,
                particle_density_source=args.density or "",
                particle_probability_source=args.probability or "", particle_size_source=args.size or "",
                particle_background=(args.background or d.particle_background.lower()).upper())


def prepare_cli_run(args, run):
    """--labels read bottom row first (then removed), --write-labels, --instances example; ValueError on a
    missing file."""
    import bpy
    from ..bridge import images, mesh_io
    if args.labels:
        if not os.path.isfile(args.labels):
            raise ValueError("label image not found: %s" % args.labels)
        image = bpy.data.images.load(os.path.abspath(args.labels))
        try:
            run.label_pixels = mesh_io.read_image_pixels(image)[::-1]
        finally:
            bpy.data.images.remove(image)
    if args.write_labels:
        from . import core, synthesis
        analysis, _, _ = synthesis.analyse(run.sample, run.settings, run.cache_dir, run.label_pixels)
        images.write_png(os.path.abspath(args.write_labels), core.label_image(analysis))
    if args.instances == "example" and bpy.data.collections.get("example") is None:
        sys.path.insert(0, os.path.join(REPOSITORY, "blend_samples"))
        try:
            import particle_instances
        except ImportError:
            raise ValueError("--instances example needs blend_samples/particle_instances.py (run from the repository)")
        run.settings.particle_collection = particle_instances.make_collection().name


PARTICLES = MethodSpec(
    "PARTICLES", "particles", "Texture Particles",
    "Cut the sample into its elements (pebbles, leaves, spots) and scatter them whole over the surface as decals "
    "or 3D instances, keeping their arrangement (Dischler et al.)",
    reads_label_image=True, extra_panels=("TEXSYNTH_PT_particles",), validate=validate, draw=draw, panel_settings=panel_settings,
    make_job=make_job, synthesize=synthesize)
FAMILY = MethodFamily(
    "particles", (PARTICLES,),
    settings_fields=("particle_classes", "particle_blur", "particle_min_area", "particle_touching",
                     "particle_background_class",
                     "particle_merges", "particle_class_order", "particle_output", "particle_collection",
                     "particle_size_jitter", "particle_density_source", "particle_probability_source",
                     "particle_size_source", "particle_background"),
    add_cli_options=add_cli_options, check_cli_args=check_cli_args, settings_from_cli=settings_from_cli,
    prepare_cli_run=prepare_cli_run)
