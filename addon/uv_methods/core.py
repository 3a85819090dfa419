# SPDX-License-Identifier: GPL-3.0-or-later
"""bpy-free core of the UV methods (jump maps, texton strings): preprocessing and its cache, the
shader blend's inputs (Auto's choice, histogram files), and the native synthesis calls."""
import dataclasses
import os

import numpy as np

from .. import native
from ..core.layers import EDGE_BLENDED_NAME, EDGE_ERROR_NAME
from ..core.messages import reworded_for
from ..core.sample_image import correlation_length, load_sample, periodicity, sample_pixels, sample_size, shader_mean
from ..core.settings import AUTO_HISTOGRAM_MIN_FIDELITY, AUTO_TEXTON_LINEAR_PERIODICITY, HISTOGRAM_MAX_PIXELS, SettingsError
from .encoding import check_result, mapping_groups_rgba

# Texton method: each face shows its own patch beyond this distance from its edges (barycentric-like units, 1/3
# at a triangle's centre) and fades to the vertex mappings toward them (shading/blend_groups.py). Variance and
# histogram blending keep the contrast through the fade, so where it mixes distinct patches the fade is itself an
# edge: at 0.15 (1-3 px on faces of 10-40 px) it raised the seam ratio above the unblended render on small
# samples, where most zones mix distinct patches (docs/algorithms/texton_strings.md, "Small samples"). Linear
# blending dims the mixture instead and keeps the narrower zone (a wider one washes out more detail).
TEXTON_PATCH_ZONE = 0.3
TEXTON_LINEAR_PATCH_ZONE = 0.15


def patch_zone(method, mode="HISTOGRAM"):
    """The blend shader's own-patch zone of a UV method for a resolved blend mode (0: the jump map blends
    everywhere)."""
    if method != "TEXTON":
        return 0.0
    return TEXTON_LINEAR_PATCH_ZONE if mode == "LINEAR" else TEXTON_PATCH_ZONE


def cache_status(sample, settings, cache_dir):
    """'fresh' | 'missing' | 'stale' for the sample's cached preprocessing."""
    module = native.require()
    return module.cache_status(load_sample(sample), cache_dir=cache_dir, **settings.preprocess_params())


def preprocess(sample, settings, cache_dir, cancel=None):
    """Preprocessed sample (from the cache when fresh). Errors: SettingsError/ValueError with a message.
    cancel: a texsynth_native.CancelToken (the call then raises texsynth_native.Cancelled when raised)."""
    module = native.require()
    if cache_dir:
        os.makedirs(cache_dir, exist_ok=True)
    extra = {} if cancel is None else {"cancel": cancel}
    return module.preprocess(load_sample(sample), cache_dir=cache_dir or None, **settings.preprocess_params(), **extra)


def interpolation_fidelity(pixels, gaussian, inverse_lut, shift=0.5, max_side=256):
    """How much luminance gradient survives when the sample is interpolated in Gaussianized space
    (as the histogram blend's texture look-ups do) instead of in colour space: mean |grad L| of the
    image resampled half a texel off in both axes through the Gaussian image and the inverse table,
    divided by the same resampling of the sample itself. Near 1 for most samples; well below 1 when
    the histogram is skewed (moss: rare bright speckles shrink, 0.93), where a render through the
    histogram blend loses that much detail (measured in README, "Blending"). Centred crop of max_side."""
    def crop(a):
        a = np.asarray(a, dtype=np.float64)
        top, left = max(0, (a.shape[0] - max_side) // 2), max(0, (a.shape[1] - max_side) // 2)
        a = a[top:top + max_side, left:left + max_side]
        return a[:, :, :1] if a.shape[2] <= 2 else a[:, :, :3]

    def resample(a):
        f = float(shift)
        return ((1 - f) * (1 - f) * a[:-1, :-1] + f * (1 - f) * (a[1:, :-1] + a[:-1, 1:]) + f * f * a[1:, 1:])

    def gradient(colour):
        lum = colour.mean(axis=2) if colour.shape[2] != 3 else colour @ np.array([0.2126, 0.7152, 0.0722])
        return float(np.hypot(np.diff(lum, axis=1)[:-1], np.diff(lum, axis=0)[:, :-1]).mean())

    colour, gauss = crop(pixels), crop(gaussian)
    table = np.asarray(inverse_lut, dtype=np.float64).reshape(-1, np.shape(inverse_lut)[-1])
    size = table.shape[0]
    shifted = resample(gauss)
    looked_up = np.empty_like(shifted)
    entries = np.arange(size)
    for c in range(shifted.shape[2]):
        position = np.clip(shifted[..., c] * size - 0.5, 0, size - 1)
        looked_up[..., c] = np.interp(position.ravel(), entries, table[:, min(c, table.shape[1] - 1)]).reshape(position.shape)
    reference = gradient(resample(colour))
    return gradient(looked_up) / reference if reference > 1e-9 else 1.0


@dataclasses.dataclass
class HistogramFiles:
    """The Gaussianized sample and its inverse look-up table, as files next to the cache."""
    gaussian_path: str
    lut_path: str


@dataclasses.dataclass
class BlendShading:
    """What the shader's blend needs from the sample (see blend_groups.BlendInputs)."""
    mode: str = "LINEAR"
    mean: tuple = (0.5, 0.5, 0.5)
    files: HistogramFiles = None
    correlation_length: float = 1.0  # texels, of the image the blend reads (Gaussianized for HISTOGRAM)
    note: str = ""                   # why HISTOGRAM fell back to VARIANCE, if it did (a warning)
    reason: str = ""                 # why Auto chose the mode (information)
    means: dict = None               # VARIANCE: {srgb: mean} for both readings of the sample

    def with_colour_space(self, srgb):
        """Picks the mean for how Blender reads the image (known once the bpy image is loaded)."""
        if self.means:
            self.mean = self.means[bool(srgb)]
        return self


def blend_shading(native_input, settings, cache_dir, srgb=None):
    """BlendShading for the sample: the Gaussianization is computed (or read from the cache) for
    HISTOGRAM; a sample it cannot serve falls back to VARIANCE, and `note` says why. Without `srgb`
    (the bpy image not loaded yet: it is only loaded once the native calls accepted the file) both
    means are kept; with_colour_space picks one."""
    if not settings.blend:
        return BlendShading()
    result = BlendShading(mode=settings.resolved_blend_mode())
    decoded = []  # the sample's pixels, decoded once for whichever measurements need them

    def pixels():
        if not decoded:
            decoded.append(sample_pixels(native_input))
        return decoded[0]

    if settings.blend_mode == "AUTO" and settings.method == "TEXTON":
        repeat = periodicity(pixels())
        result.mode = "LINEAR" if repeat >= AUTO_TEXTON_LINEAR_PERIODICITY else "VARIANCE"
        result.reason = "Auto: %s sample, periodicity %.2f" % (
            "periodic" if result.mode == "LINEAR" else "stochastic", repeat)
    looked_up = None
    if result.mode == "HISTOGRAM":
        width, height = sample_size(native_input)
        if width * height > HISTOGRAM_MAX_PIXELS:
            # Its Gaussianized float copy (and the EXR Blender would load) is capped at 4096²; 8K samples
            # are accepted by the analysis (working size), so they blend with the variance-preserving mode.
            result.mode = "VARIANCE"
            result.note = ("histogram-preserving blending unavailable (the sample is %dx%d, above its 4096x4096 "
                           "limit): variance-preserving used" % (width, height))
    if result.mode == "HISTOGRAM":
        transform = native.require().histogram_transform(load_sample(native_input), cache_dir=cache_dir)
        fidelity = 1.0
        if transform["ok"] and settings.blend_mode == "AUTO" and transform.get("gaussian") is not None:
            fidelity = interpolation_fidelity(pixels(), transform["gaussian"], transform["inverse_lut"])
        if transform["ok"] and fidelity >= AUTO_HISTOGRAM_MIN_FIDELITY:
            result.files = HistogramFiles(transform["gaussian_path"], transform["lut_path"])
            looked_up = transform.get("gaussian")
        elif transform["ok"]:
            result.mode = "VARIANCE"
            result.reason = "Auto: the histogram transform keeps %.0f %% of this sample's detail" % (100.0 * fidelity)
        else:
            result.mode = "VARIANCE"
            result.note = "histogram-preserving blending unavailable (%s): variance-preserving used" % (
                transform["fallback_reason"])
    if result.mode == "VARIANCE":
        looked_up = pixels()
        result.means = {space: shader_mean(looked_up, space) for space in (False, True)}
        result.with_colour_space(bool(srgb))
    if looked_up is not None and np.ndim(looked_up) == 3:
        result.correlation_length = correlation_length(looked_up)
    return result


@dataclasses.dataclass
class View:
    """The scene camera for the blending metric: world position and λ (pixels per radian)."""
    position: tuple
    pixels_per_radian: float


def synthesize(preprocessed, mesh_arrays, settings, seed, scale, pixels=None, view=None, cancel=None):
    """Runs the native synthesizer on one mesh; returns its dict after checking every shape.
    TEXTON needs `pixels` (sample_pixels) and, with a blend threshold, `view`. cancel: a
    texsynth_native.CancelToken, as for preprocess()."""
    module = native.require()
    if mesh_arrays.num_faces == 0:
        raise SettingsError("mesh has no faces")
    # pack_sets: blend sets come back as blend_set_pairs, the layout of the RGBA set attributes.
    kwargs = dict(scale=float(scale), seed=int(seed), pack_sets=True,
                  blend=bool(settings.blend), allow_oversized=bool(settings.allow_oversized))
    if settings.orientation == "AXIS":
        kwargs.update(orientation="axis", axis=tuple(float(c) for c in settings.axis))
    elif settings.orientation == "FIELD":
        kwargs.update(orientation="field", direction=_require_direction(mesh_arrays, settings))
    else:
        direction = _require_direction(mesh_arrays, settings)
        anchors = np.flatnonzero(np.linalg.norm(direction, axis=1) > 1e-12).astype(np.int32)
        if anchors.size == 0:
            raise SettingsError("attribute %r has no non-zero vectors: no anchors" % settings.direction_attribute)
        kwargs.update(orientation="anchors", anchor_vertices=anchors,
                      anchor_directions=np.ascontiguousarray(direction[anchors]))
    if mesh_arrays.scale_multiplier is not None:
        kwargs.update(scale_multiplier=mesh_arrays.scale_multiplier)
    mesh = (mesh_arrays.positions, mesh_arrays.corner_verts, mesh_arrays.poly_starts, mesh_arrays.poly_sizes)
    if cancel is not None:
        kwargs.update(cancel=cancel)
    if settings.method == "TEXTON":
        if pixels is None:
            raise SettingsError("the texton method needs the sample pixels")
        if view is not None:
            kwargs.update(camera_position=tuple(float(c) for c in view.position),
                          lambda_=float(view.pixels_per_radian))
        if settings.blend_threshold > 0.0:
            if view is None:
                raise SettingsError("a blend threshold needs a scene camera (the blending metric is view-dependent)")
            kwargs.update(blend_threshold=float(settings.blend_threshold))
        with reworded_for(settings, SettingsError):
            result = dict(module.synthesize_texton(preprocessed, pixels, *mesh, **kwargs))
        result["corner_attributes"] = {
            EDGE_BLENDED_NAME: np.asarray(result.pop("corner_edge_blended"), dtype=np.float32),
            EDGE_ERROR_NAME: np.asarray(result.pop("corner_edge_error"), dtype=np.float32)}
        if settings.blend and int(result["num_blend_sets"]):
            check_result(result, int(mesh_arrays.corner_verts.size))
            result["mapping_groups"] = mapping_groups_rgba(result, mesh_arrays.poly_starts, mesh_arrays.poly_sizes)
    else:
        kwargs.update(jump_rate=float(settings.jump_rate))
        with reworded_for(settings, SettingsError):
            result = dict(module.synthesize_jumpmap(preprocessed, *mesh, **kwargs))
    if not settings.blend:
        # Without blending the native single set is the base mapping with weight 1: write the base only.
        result.update(num_blend_sets=0, blend_uv=None, blend_set_pairs=None, blend_weights=None)
    return result  # validated by mesh_write.write_result before anything is written


def _require_direction(mesh_arrays, settings):
    if mesh_arrays.direction is None:
        raise SettingsError("mesh has no vector attribute %r for the orientation" % settings.direction_attribute)
    return mesh_arrays.direction
