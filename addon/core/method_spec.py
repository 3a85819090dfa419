# SPDX-License-Identifier: GPL-3.0-or-later
"""What a synthesis method declares to the registry (methods.py), bpy-free and numpy-free so the command
line can build its parser from it before the add-on loads. A family (uv_methods/, surface_colour/,
particles/) declares one MethodFamily in its method.py: its methods, its command-line options and the
settings it owns; the panel, operators and CLI ask these objects instead of comparing method names."""
import dataclasses


@dataclasses.dataclass
class RunRequest:
    """What an interface hands a method's job factory: the same for the panel and the command line."""
    objects: list
    sample: object                   # bridge.sources.Sample
    settings: object                 # core.settings.Settings, validated by the job
    cache_dir: str = ""              # '' = the default cache folder
    material_mode: str = "NEW"
    bake_request: object = None      # core.bake_options.BakeRequest (surface colours: the image target)
    context: object = None           # bpy.context (surface colours read the scene's colour management)
    scene: object = None
    label_pixels: object = None      # particles: a label image, bottom row first
    only_class: object = None        # particles: re-synthesize one class


def _nothing(*_args, **_kwargs):
    return None


def _no_settings(*_args, **_kwargs):
    return {}


@dataclasses.dataclass
class MethodSpec:
    """One entry of the Method menu and of --method."""
    id: str                          # Settings.method and the panel's enum identifier, e.g. "ROUND"
    cli_name: str                    # --method value, e.g. "round"
    label: str                       # the menu's name
    description: str                 # the menu's tooltip
    # Capabilities the interfaces ask instead of comparing names:
    writes_uv: bool = False          # coordinates + blend layers: preprocessing cache, Bake after synthesis
    colours_surface: bool = False    # a colour per texel or vertex (surface target), kept only in the scene
    reads_label_image: bool = False  # the panel's label image goes into the RunRequest
    extra_panels: tuple = ()         # bl_idname of sub-panels shown only for this method
    live_update: str = ""            # field edits: "" = refused, "UV" = re-synthesize, "PREVIEW" = own preview
    live_from_memory: bool = False   # the live update may re-synthesize from mesh arrays in memory
    auto_blend_mode: str = "HISTOGRAM"  # what Blend Mode Auto takes for this method (README, Blending)
    # Parts (functions); the family fills them:
    validate: object = _nothing      # validate(settings): SettingsError for this method's own settings
    draw: object = _nothing          # draw(layout, props, context): this method's part of the Method panel
    panel_settings: object = _no_settings  # panel_settings(props) -> {Settings field: value} it parses itself
    make_job: object = None          # make_job(RunRequest) -> a Job (prepare / compute / apply)
    synthesize: object = None        # synthesize(RunRequest) -> Report, every stage in this thread


@dataclasses.dataclass
class MethodFamily:
    """A family's methods and its command-line options (shared by its methods, added to the parser once)."""
    name: str                        # the package, e.g. "surface_colour"
    methods: tuple                   # MethodSpec, in menu order
    settings_fields: tuple = ()      # Settings fields this family owns (their defaults: core/settings.py)
    add_cli_options: object = _nothing     # add_cli_options(parser, defaults)
    # check_cli_args(args, spec, defaults): the message of a misplaced option or None; fills the family's
    # option defaults. check_cli_outputs(args, spec): the same for the output options (--bake ...), later.
    check_cli_args: object = _nothing
    check_cli_outputs: object = _nothing
    settings_from_cli: object = _no_settings  # settings_from_cli(args, spec, defaults) -> {Settings field: value}
    prepare_cli_run: object = _nothing        # prepare_cli_run(args, RunRequest): inputs only the CLI reads
    # A family's own settings outside core/settings.py: {name: default} (Settings.method_options), and the
    # panel's properties for them, panel_properties(bpy.props) -> {name: property} (added to the scene's settings).
    option_defaults: dict = dataclasses.field(default_factory=dict)
    panel_properties: object = _no_settings

    def cli_names(self):
        return [spec.cli_name for spec in self.methods]
