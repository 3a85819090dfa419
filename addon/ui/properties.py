# SPDX-License-Identifier: GPL-3.0-or-later
"""Scene settings (persist in the .blend) and add-on preferences."""
import bpy

from .. import methods
from ..bridge import sources
from ..core import bake_options
from ..core.settings import (PARTICLE_CLASS_RANGE, PARTICLE_MAX_BLUR, PARTICLE_MAX_JITTER, PATCH_BOUNDARY_RANGE,
    PATCH_ITERATION_RANGE, PATCH_SIZE_RANGE, PATCH_TOLERANCE_RANGE, ROUND_CANDIDATE_RANGE, ROUND_LEVEL_RANGE,
    ROUND_RING_RANGE, Settings, WORKING_SIZE_RANGE)

# Every default of the panel is the Settings default (core/settings.py): written once, there.
DEFAULTS = Settings()

ADDON_ID = __package__


class TexSynthParticleClass(bpy.types.PropertyGroup):
    """One row of the particle analysis view (filled by Analyse Sample)."""
    class_id: bpy.props.IntProperty(name="Class")
    colour: bpy.props.FloatVectorProperty(name="Colour", subtype="COLOR", size=3, min=0.0, max=1.0)
    pixels: bpy.props.IntProperty(name="Pixels")
    particles: bpy.props.IntProperty(name="Particles")
    complete: bpy.props.IntProperty(name="Complete")
    background: bpy.props.BoolProperty(name="Background")
    random: bpy.props.BoolProperty(name="Random")


class TexSynthSettings(bpy.types.PropertyGroup):
    sample_source: bpy.props.EnumProperty(
        name="Sample", items=(("FILE", "File", "An image file on disk"),
                              ("IMAGE", "Image", "An image in this .blend (packed images too)")),
        default="FILE")
    sample_path: bpy.props.StringProperty(name="Sample File", subtype="FILE_PATH",
                                          description="Sample texture image file")
    sample_image: bpy.props.PointerProperty(name="Sample Image", type=bpy.types.Image,
                                            description="Sample texture image in this .blend")
    method: bpy.props.EnumProperty(name="Method", items=methods.enum_items(), default=DEFAULTS.method)
    particle_classes: bpy.props.IntProperty(
        name="Classes", default=DEFAULTS.particle_classes, min=PARTICLE_CLASS_RANGE[0], max=PARTICLE_CLASS_RANGE[1],
        description="Colour classes the sample is segmented into (background included)")
    particle_blur: bpy.props.FloatProperty(
        name="Blur", default=DEFAULTS.particle_blur, min=0.0, max=PARTICLE_MAX_BLUR, subtype="PIXEL",
        description="Smoothing before segmentation (sample pixels): higher ignores fine texture inside elements")
    particle_min_area: bpy.props.IntProperty(
        name="Min Area", default=DEFAULTS.particle_min_area, min=0, subtype="PIXEL",
        description="Smaller regions join the background (0: automatic, max(16 px, 0.02 % of the sample))")
    # Numbers: a .blend saved when this was a checkbox (0 / 1) reads back as Off / On.
    particle_touching: bpy.props.EnumProperty(
        name="Touching Elements",
        items=(("AUTO", "Auto", "Split touching elements where one segmented region spans a fifth of the sample "
                "(a lace of gaps, or elements joined into a network), or take elements whole where they come out "
                "cut into pieces of very different sizes (leaves cut by their veins), unless that cuts more "
                "elements at the sample's border", 2),
               ("ON", "On", "Split elements that touch each other (gravel, cobbles, packed pebbles) along the narrow "
                "necks between them, and take the connected gaps as the background", 1),
               ("OFF", "Off", "Each connected region of a class is one element (separated elements)", 0)),
        default=DEFAULTS.particle_touching)
    particle_background_class: bpy.props.IntProperty(
        name="Background Class", default=DEFAULTS.particle_background_class, min=-1, max=PARTICLE_CLASS_RANGE[1] - 1,
        description="Class synthesized as texture under the particles (-1: the largest)")
    particle_merges: bpy.props.StringProperty(
        name="Merges", default="", description="Class merges a>b (class a joins b), comma separated")
    particle_class_order: bpy.props.StringProperty(
        name="Class Order", default="",
        description="Classes to place, in order, comma separated (empty: by decreasing particle count)")
    particle_label_image: bpy.props.PointerProperty(
        name="Labels", type=bpy.types.Image,
        description="Optional label image of the sample's size: one flat colour per class, replaces the automatic "
                    "segmentation")
    particle_output: bpy.props.EnumProperty(
        name="Output",
        items=(("DECALS", "Decals", "Per class a decal mesh on the surface showing the particles' sprites"),
               ("INSTANCES", "Instances", "Per class points instancing objects of a collection (Geometry Nodes)"),
               ("BOTH", "Both", "Decals and instances")),
        default=DEFAULTS.particle_output)
    particle_collection: bpy.props.PointerProperty(
        name="Instances", type=bpy.types.Collection,
        description="Objects placed per class (child i for class i, wrapping): any objects, e.g. a thorn")
    particle_size_jitter: bpy.props.FloatProperty(
        name="Size Jitter", default=DEFAULTS.particle_size_jitter, min=0.0, max=PARTICLE_MAX_JITTER, subtype="FACTOR",
        description="Each particle's size varies by up to this fraction")
    particle_density_source: bpy.props.StringProperty(
        name="Density", default=DEFAULTS.particle_density_source,
        description="Face attribute or vertex group: density factor per face (0 = none there)")
    particle_probability_source: bpy.props.StringProperty(
        name="Probability", default=DEFAULTS.particle_probability_source,
        description="Face attribute or vertex group: chance (0..1) that a particle is kept")
    particle_size_source: bpy.props.StringProperty(
        name="Size", default=DEFAULTS.particle_size_source, description="Face attribute or vertex group: size factor per face")
    particle_background: bpy.props.EnumProperty(
        name="Background",
        items=(("JUMPMAP", "Jump Map", "The filled background sample through the jump-map method"),
               ("TEXTON", "Texton Strings", "The filled background sample through texton strings"),
               ("NONE", "None", "Leave the object's own material under the particles")),
        default=DEFAULTS.particle_background)
    particle_rows: bpy.props.CollectionProperty(type=TexSynthParticleClass)
    particle_active_class: bpy.props.IntProperty(name="Class", default=0, min=0,
                                                 description="Class picked in the analysis view")
    particle_merge_into: bpy.props.IntProperty(name="Into", default=0, min=0,
                                               description="Class the picked class joins")
    particle_preview: bpy.props.PointerProperty(name="Segmentation", type=bpy.types.Image)
    surface_target: bpy.props.EnumProperty(
        name="Target",
        items=(("IMAGE", "Image", "Texels of an image through a UV map (see Output): export and painting ready"),
               ("VERTICES", "Vertices", "A colour attribute: one colour per vertex of a dense mesh (attribute TexSynth_Colour)")),
        default=DEFAULTS.surface_target)
    round_levels: bpy.props.IntProperty(
        name="Levels", default=DEFAULTS.round_levels, min=ROUND_LEVEL_RANGE[0], max=ROUND_LEVEL_RANGE[1],
        description="Resolution levels on the surface: more levels keep larger structures together")
    round_coarse_rings: bpy.props.IntProperty(
        name="Coarse Rings", default=DEFAULTS.round_coarse_rings, min=ROUND_RING_RANGE[0], max=ROUND_RING_RANGE[1],
        description="Neighbourhood radius (in rings of samples) at the coarsest level, which lays out the structure")
    round_fine_rings: bpy.props.IntProperty(
        name="Fine Rings", default=DEFAULTS.round_fine_rings, min=ROUND_RING_RANGE[0], max=ROUND_RING_RANGE[1],
        description="Neighbourhood radius at the finer levels, which refine the detail")
    round_resolution: bpy.props.EnumProperty(
        name="Resolution",
        items=(("AUTO", "Match Target", "Synthesize from the sample reduced to the target's texel density when the "
                                        "target is coarser (what a mipmap would show; keeps thin features whole)"),
               ("FULL", "Full Sample", "Always synthesize from the full-resolution sample")),
        default=DEFAULTS.round_resolution)
    round_candidates: bpy.props.IntProperty(
        name="Random Candidates", default=DEFAULTS.round_candidates, min=ROUND_CANDIDATE_RANGE[0],
        max=ROUND_CANDIDATE_RANGE[1],
        description="Random sample positions tried per point at the coarsest level: more gives more variety")
    patch_mode: bpy.props.EnumProperty(
        name="Mode",
        items=(("SAMPLING", "Patch Sampling", "Paste patches whose boundary zones match what is already there "
                                              "(fast; the live preview uses it)"),
               ("OPTIMISATION", "Optimisation", "Start from patch sampling, then refine every patch by texture "
                                                "optimisation (slower, fewer broken structures)")),
        default=DEFAULTS.patch_mode)
    patch_size: bpy.props.IntProperty(
        name="Patch Size", default=DEFAULTS.patch_size, min=PATCH_SIZE_RANGE[0], max=PATCH_SIZE_RANGE[1], step=4,
        description="Patch width in sample pixels (a multiple of 4): larger keeps larger structures whole")
    patch_boundary: bpy.props.IntProperty(
        name="Boundary", default=DEFAULTS.patch_boundary, min=PATCH_BOUNDARY_RANGE[0], max=PATCH_BOUNDARY_RANGE[1],
        description="Width in sample pixels of the zone where a new patch is matched and cross-faded into its "
                    "neighbours: at most half the patch size (of the smaller patches a small sample or a coarse "
                    "optimisation level gets)")
    patch_tolerance: bpy.props.FloatProperty(
        name="Tolerance", default=DEFAULTS.patch_tolerance, min=PATCH_TOLERANCE_RANGE[0], max=PATCH_TOLERANCE_RANGE[1],
        description="Candidates matching within this factor of the best are equally likely: higher gives more "
                    "variety, lower better fits")
    patch_iterations: bpy.props.IntProperty(
        name="Iterations", default=DEFAULTS.patch_iterations, min=PATCH_ITERATION_RANGE[0], max=PATCH_ITERATION_RANGE[1],
        description="Optimisation passes over every patch")
    scale: bpy.props.FloatProperty(name="Scale", subtype="DISTANCE", default=DEFAULTS.sample_world_size, min=1e-4, soft_max=100.0,
                                   description="World size of the sample's width: one sample spans this many "
                                               "world units on every selected object")
    seed: bpy.props.IntProperty(name="Seed", default=DEFAULTS.seed, min=0)
    neighbourhood: bpy.props.IntProperty(
        name="Neighbourhood", default=DEFAULTS.neighbourhood, min=3, max=25, step=2, subtype="PIXEL",
        description="Window (in analysis pixels, odd) that textons and jumps compare")
    working_size: bpy.props.IntProperty(
        name="Analysis Size", default=DEFAULTS.working_size, min=0, max=WORKING_SIZE_RANGE[1], subtype="PIXEL",
        description="Longest side of the copy the sample is analysed at (0: its own resolution, at most 4096 "
                    "pixels). The material still shows the full image")
    jump_rate: bpy.props.FloatProperty(name="Jump Rate", default=DEFAULTS.jump_rate, min=0.0, soft_max=100.0,
                                       description="How often the walk jumps to a similar sample location")
    orientation: bpy.props.EnumProperty(
        name="Orientation",
        items=(("AXIS", "Global Axis", "Texture 'up' follows a global axis projected onto the surface"),
               ("FIELD", "Direction Attribute", "A vertex vector attribute gives the direction everywhere"),
               ("ANCHORS", "Anchors", "Vertices with a non-zero vector in the attribute are anchors; "
                                      "the direction is interpolated between them")),
        default=DEFAULTS.orientation)
    axis: bpy.props.FloatVectorProperty(name="Axis", size=3, default=DEFAULTS.axis, subtype="XYZ")
    direction_attribute: bpy.props.StringProperty(name="Attribute", default="TexSynth_Direction",
                                                  description="Vertex FLOAT_VECTOR attribute name "
                                                              "(TexSynth_Direction is the field the Field tools edit)")
    scale_source: bpy.props.EnumProperty(
        name="Scale Map",
        items=(("NONE", "Uniform", "The same scale everywhere"),
               ("ATTRIBUTE", "Attribute", "A float vertex attribute multiplies the texture density "
                                          "(2 = features half as large)"),
               ("VERTEX_GROUP", "Vertex Group", "Weight-painted vertex group mapped to the Min..Max range")),
        default=DEFAULTS.scale_source)
    scale_attribute: bpy.props.StringProperty(name="Scale Attribute", default=DEFAULTS.scale_attribute,
                                              description="Float vertex attribute: density multiplier (> 0)")
    scale_group: bpy.props.StringProperty(name="Vertex Group", default=DEFAULTS.scale_group,
                                          description="Vertex group whose weights map to the density range")
    scale_min: bpy.props.FloatProperty(name="Min", default=DEFAULTS.scale_min, min=1e-3, soft_max=10.0,
                                       description="Density multiplier at weight 0")
    scale_max: bpy.props.FloatProperty(name="Max", default=DEFAULTS.scale_max, min=1e-3, soft_max=10.0,
                                       description="Density multiplier at weight 1")
    field_brush_radius: bpy.props.FloatProperty(name="Radius", subtype="DISTANCE", default=0.2, min=1e-5,
                                                soft_max=10.0, description="Comb / stroke brush radius (world units)")
    field_brush_strength: bpy.props.FloatProperty(name="Strength", default=1.0, min=0.0, max=1.0,
                                                  description="How far a dab turns existing anchors")
    field_erase: bpy.props.BoolProperty(name="Erase", default=False,
                                        description="The comb removes anchors (also: hold Ctrl while dragging)")
    show_field: bpy.props.BoolProperty(name="Show Field", default=False,
                                       description="Draw the direction field as arrows on the active object")
    field_arrow_density: bpy.props.FloatProperty(name="Density", default=0.25, min=0.001, max=1.0,
                                                 subtype="FACTOR", description="Fraction of vertices with an arrow")
    field_arrow_length: bpy.props.FloatProperty(name="Arrow Length", default=1.0, min=0.05, soft_max=5.0,
                                                description="Arrow length in mean edge lengths")
    field_live_update: bpy.props.BoolProperty(
        name="Live Update", default=False,
        description="Re-synthesize the object after each field edit (uses the cached sample)")
    blend: bpy.props.BoolProperty(name="Blending", default=DEFAULTS.blend,
                                  description="Write blend sets and weights that hide patch seams")
    blend_mode: bpy.props.EnumProperty(
        name="Blend Mode",
        items=(("AUTO", "Auto", "What measured best per sample: jump maps take Histogram, or Variance when the "
                                "histogram transform would lose the sample's detail; texton strings take Linear "
                                "for periodic samples, Variance for stochastic ones"),
               ("HISTOGRAM", "Histogram", "Keep the sample's contrast and colours where patches overlap "
                "(Gaussianized look-ups; slightly more shader work)"),
               ("VARIANCE", "Variance", "Keep the sample's contrast where patches overlap"),
               ("LINEAR", "Linear", "Plain cross-fade: cheapest, but overlaps look washed out")),
        default=DEFAULTS.blend_mode)
    blend_threshold: bpy.props.FloatProperty(
        name="Blend Threshold", default=DEFAULTS.blend_threshold, min=0.0, soft_max=50.0,
        description="Texton method: blend only edges whose seam, seen from the scene camera, exceeds this "
                    "(colour error × edge length in pixels); 0 blends every edge")
    allow_oversized: bpy.props.BoolProperty(
        name="Allow Oversized Faces", default=DEFAULTS.allow_oversized,
        description="Also map faces larger than the sample at this scale (otherwise they are refused: "
                    "subdivide them or raise the scale)")
    material_mode: bpy.props.EnumProperty(
        name="Material",
        items=(("NEW", "New Material", "Assign a ready material using the TexSynth blend group"),
               ("INSERT", "Insert in Material", "Feed the object's existing materials' Base Color"),
               ("NONE", "Layers Only", "Only write UV layers and weights")),
        default="NEW")

    # Bake (see core/bake_options.py)
    bake_target: bpy.props.StringProperty(
        name="Image", default="",
        description="Image name (packed, or saved next to the .blend) or a file path (.png, .exr, ...) to save to; "
                    "empty: 'TexSynth Baked: <object>'")
    bake_uv_map: bpy.props.StringProperty(
        name="UV Map", default="",
        description="UV map to bake through (not TexSynth's own, whose islands overlap); "
                    "empty: the first other UV map")
    bake_create_uv: bpy.props.BoolProperty(
        name="Create UV Map if Missing", default=True,
        description="When the object has no UV map besides TexSynth's, make one with Smart UV Project")
    bake_size: bpy.props.IntProperty(name="Size", default=bake_options.DEFAULT_SIZE, min=bake_options.MIN_SIZE,
                                     max=bake_options.MAX_SIZE, subtype="PIXEL",
                                     description="Width and height of the baked image in pixels")
    bake_margin: bpy.props.IntProperty(name="Margin", default=bake_options.DEFAULT_MARGIN, min=0,
                                       max=bake_options.MAX_MARGIN, subtype="PIXEL",
                                       description="Pixels filled around UV islands (avoids seams in mipmaps)")
    bake_save_mode: bpy.props.EnumProperty(
        name="Store", items=(("PACK", "Pack in .blend", "Pack the baked image into the .blend"),
                             ("NEXT_TO_BLEND", "Save Next to .blend", "Save <image name>.png next to the .blend")),
        default="PACK")
    bake_material: bpy.props.EnumProperty(
        name="Baked Material",
        items=(("NONE", "None", "Only bake the image"),
               ("CREATE", "Create", "Also make 'TexSynth Baked: <object>' (image -> Base Color on the bake UV map)"),
               ("ASSIGN", "Create and Assign", "Make that material and assign it to the object")),
        default="CREATE")

    def to_bake_request(self):
        return bake_options.BakeRequest(target=self.bake_target.strip(), uv_map=self.bake_uv_map,
                                        size=int(self.bake_size), margin=int(self.bake_margin),
                                        save_mode=self.bake_save_mode, create_uv=bool(self.bake_create_uv),
                                        material=self.bake_material)

    def to_settings(self):
        return Settings(method=self.method, sample_world_size=float(self.scale), seed=int(self.seed),
                                 jump_rate=float(self.jump_rate), blend=bool(self.blend),
                                 neighbourhood=int(self.neighbourhood) | 1, working_size=int(self.working_size),
                                 blend_mode=self.blend_mode,
                                 orientation=self.orientation, axis=tuple(self.axis),
                                 direction_attribute=self.direction_attribute,
                                 allow_oversized=bool(self.allow_oversized),
                                 blend_threshold=float(self.blend_threshold),
                                 scale_source=self.scale_source, scale_attribute=self.scale_attribute,
                                 scale_group=self.scale_group, scale_min=float(self.scale_min),
                                 scale_max=float(self.scale_max), surface_target=self.surface_target,
                                 round_levels=int(self.round_levels), round_coarse_rings=int(self.round_coarse_rings),
                                 round_fine_rings=int(self.round_fine_rings),
                                 round_candidates=int(self.round_candidates),
                                 round_resolution=self.round_resolution, patch_mode=self.patch_mode,
                                 patch_size=int(self.patch_size) // 4 * 4, patch_boundary=int(self.patch_boundary),
                                 patch_tolerance=float(self.patch_tolerance),
                                 patch_iterations=int(self.patch_iterations), interface="PANEL",
                                 **methods.get(self.method).panel_settings(self))


# Each family's own panel properties (MethodFamily.panel_properties), declared in its package.
for _family in methods.FAMILIES:
    TexSynthSettings.__annotations__.update(_family.panel_properties(bpy.props))


class TexSynthPreferences(bpy.types.AddonPreferences):
    bl_idname = ADDON_ID

    cache_dir: bpy.props.StringProperty(name="Cache Folder", subtype="DIR_PATH", default="",
                                        description="Where preprocessed samples are cached (empty: default)")

    def draw(self, context):
        from .. import native
        self.layout.prop(self, "cache_dir")
        self.layout.label(text="Default: " + sources.default_cache_dir())
        if native.reason():
            self.layout.label(text=native.reason(), icon="ERROR")


def cache_dir(context):
    """The preference's cache folder ('' when unset or when not installed as an add-on)."""
    addon = context.preferences.addons.get(ADDON_ID)
    if addon is None or addon.preferences is None:
        return ""
    return bpy.path.abspath(addon.preferences.cache_dir) if addon.preferences.cache_dir else ""


classes = (TexSynthParticleClass, TexSynthSettings, TexSynthPreferences)
