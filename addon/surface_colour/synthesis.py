# SPDX-License-Identifier: GPL-3.0-or-later
"""One Synthesize run of a surface-colour method (round neighbourhoods, vector-field patches) over Blender
objects, shared by
the operator and the CLI. Same stages as uv_methods.synthesis.Job:

prepare()  main thread: validates, reads every mesh (loop triangles and the target UV map) and the
           sample; adds a Smart UV Project map where asked and needed (undone by discard()).
compute()  any thread: native calls only (GIL released), cancellable; progress via live_fraction().
apply()    main thread: per object, the image (packed or saved) or the colour attribute, and the material.

Nothing but the UV maps made by prepare() exists before apply(); discard() removes those, so a run that
is cancelled or fails leaves every mesh and image as it was.
"""
import dataclasses

import bpy
import numpy as np

from .. import native
from ..bridge import images, mesh_io, sources, uv_maps
from ..fields import mesh_state
from ..core import bake_options as options
from ..core.jobs import Cancelled
from ..core.reporting import Report, Timings
from ..core.sample_image import repeats_across_border, synthesis_sample
from ..core.settings import SURFACE_METHODS, SettingsError, object_seed, texels_per_unit
from ..core.names import fit_name
from ..shading import surface_material
from . import core
from . import round_neighbourhoods as round_core
from . import patches as patches_core

MATERIAL_PREFIX = "TexSynth Surface: "
# Share of the progress bar per stage when the context is built (the synthesis measures ~60% of the time).
STAGES = {"context": (0.0, 0.4), "synthesis": (0.4, 0.6)}


class _Item:
    def __init__(self, obj, arrays):
        self.obj, self.arrays = obj, arrays
        self.triangles = self.corner_uvs = None
        self.uv_map = ""
        self.created_uv = ""
        self.target = None        # options.Target (IMAGE)
        self.result = None


class Job:
    def __init__(self, objects, sample, settings, request=None, material_mode="NEW", context=None, cache_dir=""):
        self.objects, self.sample, self.settings = objects, sample, settings
        self.cache_dir = cache_dir  # PATCHES: where analysed samples are kept ('' = memory only)
        self.request = request or options.BakeRequest(create_uv=True)
        self.material_mode, self.context = material_mode, context or bpy.context
        self.report, self.timings = Report(uses_cache=False), Timings()
        self.items = []
        self.token = None
        self.cancelled = False
        self.stage = ("context", 0, 1)
        self._stale_progress = None  # the token's value left by the previous native call
        self.repeat_found, self.synthesis_settings = False, settings  # prepare() decides

    # -- main thread --------------------------------------------------------------------------

    def prepare(self):
        settings = self.settings.validate()
        if settings.method not in SURFACE_METHODS:
            raise SettingsError("method %r is not a surface-colour method" % settings.method)
        meshes, self.report.failures = sources.mesh_objects(self.objects)
        if not meshes:
            raise SettingsError("no mesh object selected")
        image_target = settings.surface_target == "IMAGE"
        if image_target:
            self.request.validate()
            if self.request.target and len(meshes) > 1:
                raise SettingsError("image %r can hold one object's texture; %d objects are selected "
                                             "(leave the image name empty for one image per object)"
                                             % (self.request.target, len(meshes)))
        module = native.require()
        self.token = module.CancelToken()
        with self.timings.phase("read"):
            pixels, self.sample_srgb = sources.read_sample_pixels(self.sample)
            self.sample_array = synthesis_sample(pixels)
            # A sample that repeats is read as with Tileable on, once per run for every object and both methods
            # (round_neighbourhoods.md, "Tileable samples"): without it round's candidates keep the coarsest
            # rings' width off every border (a 64² sample leaves an 8 x 8 choice) and patches start a patch's
            # width off it.
            self.repeat_found = not settings.tileable and repeats_across_border(self.sample_array)
            self.synthesis_settings = dataclasses.replace(settings, tileable=True) if self.repeat_found else settings
        self.texels_per_unit = texels_per_unit(int(pixels.shape[1]), settings.sample_world_size)
        for obj in meshes:
            item = None
            try:
                with self.timings.phase("read"):
                    arrays = mesh_io.read_mesh(obj, settings.direction_attribute if settings.orientation != "AXIS" else "")
                    arrays.scale_multiplier = mesh_state.read_scale_multiplier(obj, settings)
                    if arrays.num_faces == 0:
                        raise SettingsError("mesh %r has no faces" % obj.data.name)
                    item = _Item(obj, arrays)
                    if image_target:
                        self._prepare_image_target(item)
                    else:
                        item.triangles, _ = mesh_io.read_loop_triangles(obj)
                self.items.append(item)
            except (ValueError, RuntimeError) as error:
                if item is not None and item.created_uv:
                    uv_maps.remove_uv_map(obj.data, item.created_uv)
                self.report.failures.append((obj.name, str(error)))
        return self

    def _prepare_image_target(self, item):
        obj, request = item.obj, self.request
        name = request.target or fit_name(core.IMAGE_PREFIXES[self.settings.method], obj.name)
        item.target = options.resolve_target(name, obj.name, request.save_mode, bpy.data.filepath)
        item.uv_map = uv_maps.choose_uv_map(obj.data, request)
        if item.uv_map is None:
            if obj.data.library is not None:
                raise SettingsError("mesh %r is linked from a library: cannot add a UV map" % obj.data.name)
            if obj.name not in self.context.view_layer.objects:
                raise SettingsError("object %r is not in the active view layer (Smart UV Project "
                                             "needs it)" % obj.name)
            item.uv_map = item.created_uv = uv_maps.smart_project(obj, request, self.context)
            self.report.notes.append("%s: created UV map %r with Smart UV Project (it had none besides "
                                     "TexSynth's)" % (obj.name, item.created_uv))
        item.triangles, item.corner_uvs = mesh_io.read_loop_triangles(obj, item.uv_map)

    def discard(self):
        """Undoes prepare() (UV maps it created); main thread. Safe to call twice."""
        for item in self.items:
            if item.created_uv:
                try:
                    uv_maps.remove_uv_map(item.obj.data, item.created_uv)
                except ReferenceError:
                    pass
                item.created_uv = ""

    # -- any thread ---------------------------------------------------------------------------

    def cancel(self):
        self.cancelled = True
        if self.token is not None:
            self.token.cancel()

    def live_fraction(self):
        """0..1 over every object, read from the native progress (any thread)."""
        name, index, count = self.stage
        base, span = STAGES.get(name, (0.0, 1.0))
        progress = float(self.token.progress) if self.token is not None else 0.0
        if progress == self._stale_progress:
            progress = 0.0  # the next call has not reported yet
        else:
            self._stale_progress = None
        return (index + base + span * min(max(progress, 0.0), 1.0)) / max(count, 1)

    def _set_stage(self, index):
        def stage(name):
            if self.token is not None:
                self._stale_progress = float(self.token.progress)
            self.stage = (name, index, len(self.items))
        return stage

    def compute(self, progress=None):
        progress = progress or (lambda fraction, text: None)
        module = native.require()
        target_kind = self.settings.surface_target
        try:
            for index, item in enumerate(self.items):
                if self.cancelled:
                    raise module.Cancelled("cancelled")
                progress(index / max(len(self.items), 1),
                         "TexSynth: %s (%d/%d)" % (item.obj.name, index + 1, len(self.items)))
                size = self.request.size
                target = core.SurfaceTarget(target_kind, size, size, self.request.margin) \
                    if target_kind == "IMAGE" else core.SurfaceTarget("VERTICES")
                seed = object_seed(self.settings.seed, item.obj.name)
                try:
                    with self.timings.phase("synthesis"):
                        if self.settings.method == "PATCHES":
                            item.result = patches_core.synthesize_patches(
                                self.sample_array, item.arrays, item.triangles, item.corner_uvs,
                                self.synthesis_settings, seed, self.texels_per_unit, target, self.token,
                                stage=self._set_stage(index), cache_dir=self.cache_dir)
                        else:
                            item.result = round_core.synthesize_round(
                                self.sample_array, item.arrays, item.triangles, item.corner_uvs,
                                self.synthesis_settings, seed, self.texels_per_unit, target, self.token,
                                stage=self._set_stage(index))
                except module.Cancelled:
                    raise
                except (ValueError, RuntimeError) as error:
                    self.report.failures.append((item.obj.name, str(error)))
        except module.Cancelled:
            self.cancelled = True
            raise Cancelled("TexSynth: cancelled, nothing was changed") from None
        return self

    # -- main thread --------------------------------------------------------------------------

    def apply(self, progress=None):
        progress = progress or (lambda fraction, text: None)
        if self.cancelled:
            self.discard()
            raise Cancelled("TexSynth: cancelled, nothing was changed")
        for item in self.items:
            if item.result is None:
                if item.created_uv:
                    uv_maps.remove_uv_map(item.obj.data, item.created_uv)
                    item.created_uv = ""
                continue
            try:
                name = item.obj.name
                with self.timings.phase("write"):
                    if self.settings.surface_target == "IMAGE":
                        self._write_image(item)
                    else:
                        self._write_attribute(item)
                stats = dict(item.result["stats"], repeat_found=bool(self.repeat_found))
                self.report.add_object(name, item.arrays, stats)
                if stats.get("overlapping_texels"):
                    self.report.notes.append(
                        "%s: %d texels of UV map %r are covered twice (folded or overlapping UVs): each shows one "
                        "of its faces" % (name, stats["overlapping_texels"], item.uv_map))
                coarse = stats.get("sample_pixels_per_spacing", 0.0)
                if coarse > 2.0:
                    self.report.notes.append(
                        "%s: the %s is coarse for this scale (%.1f sample pixels between neighbouring surface "
                        "samples): %s for finer detail" % (name, "image" if self.settings.surface_target == "IMAGE"
                                                           else "mesh", coarse,
                                                           "raise the image size" if self.settings.surface_target
                                                           == "IMAGE" else "subdivide the mesh"))
                reduced = stats.get("memory_reduced_from")
                if reduced:
                    self.report.notes.append(
                        "%s: synthesized from the sample reduced to %d x %d (from %d x %d) to stay within the memory "
                        "limit of patch synthesis; a crop of the sample keeps its full resolution"
                        % ((name,) + tuple(stats["working_sample"]) + tuple(reduced)))
                if stats.get("context_reused"):
                    self.report.outputs.append("%s: neighbourhoods reused (only the synthesis ran)" % name)
                if stats.get("unreached_samples"):
                    self.report.notes.append(
                        "%s: %d surface samples lie where no patch reached (along boundaries or next to field "
                        "singularities): they continue the nearest patch" % (name, stats["unreached_samples"]))
            except (ValueError, RuntimeError, ReferenceError) as error:
                if item.created_uv:
                    uv_maps.remove_uv_map(item.obj.data, item.created_uv)
                self.report.failures.append((getattr(item.obj, "name", "?"), str(error)))
            item.created_uv = ""  # kept from now on: the image is painted through it
        if self.repeat_found and any(item.result is not None for item in self.items):
            self.report.notes.append("the sample repeats across its border: read as with Tileable on")
        progress(1.0, "TexSynth: done")
        self.report.seconds = self.timings.as_dict()
        return self.report

    def _write_image(self, item):
        target, result = item.target, item.result
        output_linear = target.float_buffer if target.path else not self.sample_srgb
        rgba = core.output_values(result["image"], self.sample_srgb, output_linear)
        if rgba.shape[2] == 3:
            rgba = np.concatenate([rgba, np.ones(rgba.shape[:2] + (1,), np.float32)], axis=2)
        coverage = result["mask"] > 0
        rgba[~coverage] = 0.0
        image = images.new_image(images.TEMP_PREFIX + target.image_name, self.request.size, output_linear)
        material = None
        try:
            mesh_io.fail_point("surface_image")
            # The native image's row 0 is v = 0, the bottom row; the margin is already filled.
            images.write_surface_colour(image, np.ascontiguousarray(rgba[::-1]), coverage[::-1], margin=0)
            images.store_image(image, target)
            images.take_name(image, target.image_name)
            material = surface_material.apply(item.obj, self.material_mode, fit_name(MATERIAL_PREFIX, item.obj.name),
                                              image=image, uv_map=item.uv_map)
            if material is None:
                images.keep_unused(image)  # Layers Only: the image is the output, and nothing assigns it
        except Exception:
            if image.name.startswith(images.TEMP_PREFIX):  # not yet in place of an older image
                bpy.data.images.remove(image)
            raise
        where = ("saved to %s" % target.path) if target.path else "packed"
        self.report.outputs.append("%s: image %r %dx%d (%s) through UV map %r%s" % (
            item.obj.name, image.name, image.size[0], image.size[1], where, item.uv_map,
            ", material %r" % material.name if material is not None else ""))
        item.image = image

    def _write_attribute(self, item):
        colour = core.output_values(item.result["vertex_colour"], self.sample_srgb, True)
        rgba = np.ones((colour.shape[0], 4), np.float32)
        rgba[:, :min(4, colour.shape[1])] = colour[:, :4]
        undo = mesh_io.write_colour_attribute(item.obj.data, core.COLOUR_ATTRIBUTE_NAME, rgba)
        try:
            surface_material.apply(item.obj, self.material_mode, fit_name(MATERIAL_PREFIX, item.obj.name),
                                   attribute=core.COLOUR_ATTRIBUTE_NAME)
        except Exception as error:
            undo()
            raise mesh_io.MeshWriteError("material setup failed (mesh restored): %s" % error) from error
        self.report.outputs.append("%s: colour attribute %r" % (item.obj.name, core.COLOUR_ATTRIBUTE_NAME))


def synthesize(objects, sample, settings, request=None, material_mode="NEW", progress=None, context=None,
               cache_dir=""):
    """Runs every stage; returns the Report (discarding prepare()'s changes on failure)."""
    job = Job(objects, sample, settings, request, material_mode, context, cache_dir).prepare()
    try:
        job.compute(progress)
    except BaseException:
        job.discard()
        raise
    return job.apply(progress)
