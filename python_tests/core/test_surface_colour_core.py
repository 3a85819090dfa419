# SPDX-License-Identifier: GPL-3.0-or-later
"""bpy-free part of the surface-colour methods (addon/surface_colour/core.py), under plain pytest:
colour encodings, the sample's row order, the target's density and the working sample it implies,
the settings' ranges, and the context cache."""
import re

import numpy as np
import pytest

import addon_package

core_layers = addon_package.load("core.layers")
core_settings = addon_package.load("core.settings")
core = addon_package.load("surface_colour.core")
patches_core = addon_package.load("surface_colour.patches")
round_core = addon_package.load("surface_colour.round_neighbourhoods")
sample_image = addon_package.load("core.sample_image")


def test_output_values_convert_between_encodings_and_keep_alpha():
    colour = np.array([[0.5, 0.0, 1.0, 0.25]], np.float32)
    linear = core.output_values(colour, sample_srgb=True, output_linear=True)
    # sRGB 0.5 is linear ((0.5 + 0.055) / 1.055) ** 2.4 = 0.21404 (IEC 61966-2-1).
    assert linear[0, :3] == pytest.approx([0.21404, 0.0, 1.0], abs=1e-4) and linear[0, 3] == 0.25
    assert core.output_values(linear, sample_srgb=False, output_linear=False)[0, :3] == pytest.approx(
        [0.5, 0.0, 1.0], abs=1e-4)
    assert core.output_values(colour, True, False) is colour  # same encoding: untouched


def test_synthesis_sample_is_bottom_row_first_and_always_colour():
    grey = np.arange(12, dtype=np.float32).reshape(4, 3, 1)
    out = sample_image.synthesis_sample(grey)
    assert out.shape == (4, 3, 3) and np.array_equal(out[0, :, 0], grey[3, :, 0])  # top row last
    grey_alpha = np.concatenate([grey, np.ones_like(grey)], axis=2)
    assert sample_image.synthesis_sample(grey_alpha).shape == (4, 3, 4)
    with pytest.raises(core_settings.SettingsError, match="NaN"):
        sample_image.synthesis_sample(np.full((4, 4, 3), np.nan, np.float32))
    with pytest.raises(core_settings.SettingsError, match="at least 2 x 2"):
        sample_image.synthesis_sample(np.zeros((1, 5, 3), np.float32))


def square(side=2.0):
    """Two triangles covering a side x side square, UV [0, 1]²."""
    positions = np.array([[0, 0, 0], [side, 0, 0], [side, side, 0], [0, side, 0]], np.float32)
    triangles = np.array([[0, 1, 2], [0, 2, 3]], np.int32)
    uvs = positions[triangles][:, :, :2] / side
    return positions, triangles, uvs


def test_target_density_from_uv_and_surface_areas():
    positions, triangles, uvs = square(2.0)
    image = core.SurfaceTarget("IMAGE", 128, 128)
    assert core.target_density(positions, triangles, uvs, image) == pytest.approx(64.0)  # 128 texels over 2 units
    assert core.target_density(positions, triangles, uvs * 0.5, image) == pytest.approx(32.0)
    # Vertex target: edges 2, 2 and 2√2 per triangle.
    assert core.target_density(positions, triangles, None, core.SurfaceTarget("VERTICES")) == pytest.approx(
        1.0 / ((4 + 2 * np.sqrt(2)) / 3))
    degenerate = np.zeros((4, 3), np.float32)
    assert core.target_density(degenerate, triangles, uvs, image) == 0.0


def test_working_sample_averages_down_to_the_target_density_only_when_coarser():
    blocks = np.kron(np.arange(16, dtype=np.float32).reshape(4, 4, 1), np.ones((16, 16, 3), np.float32))  # 64²
    reduced, scale = core.working_sample(blocks, 64.0, 16.0, "AUTO", minimum=4)
    assert reduced.shape == (16, 16, 3) and scale == pytest.approx(16.0)
    assert np.allclose(reduced[::4, ::4, 0], np.arange(16).reshape(4, 4))  # each 16² block -> its 4² block
    assert reduced.mean() == pytest.approx(blocks.mean())
    same, scale = core.working_sample(blocks, 64.0, 64.0, "AUTO")
    assert same is blocks and scale == 64.0  # target as fine as the sample: untouched
    same, _ = core.working_sample(blocks, 64.0, 16.0, "FULL")
    assert same is blocks
    floor, scale = core.working_sample(blocks, 64.0, 1.0, "AUTO", minimum=40)
    assert floor.shape[:2] == (40, 40) and scale == pytest.approx(40.0)


def test_working_sample_is_the_area_average_at_fractional_ratios():
    # Reference: dense weights, output pixel j covering input [j f, (j + 1) f) (fractions at both ends).
    def dense(size_in, size_out):
        f = size_in / size_out
        weights = np.zeros((size_out, size_in))
        for j in range(size_out):
            for i in range(size_in):
                weights[j, i] = max(0.0, min((j + 1) * f, i + 1) - max(j * f, i)) / f
        return weights
    sample = np.random.RandomState(3).rand(37, 300, 2).astype(np.float32)  # 300 columns: two column chunks
    reduced, scale = core.working_sample(sample, 30.0, 4.0, "AUTO", minimum=4)
    assert reduced.shape == (5, 40, 2) and reduced.dtype == np.float32 and scale == pytest.approx(4.0)
    expected = np.einsum("yh,hwc,xw->yxc", dense(37, 5), sample.astype(np.float64), dense(300, 40))
    assert np.allclose(reduced, expected, atol=1e-6)


def test_round_settings_are_range_checked():
    assert core_settings.Settings(method="ROUND").validate() is not None
    for field, value in (("round_levels", 0), ("round_levels", 7), ("round_coarse_rings", 0),
                         ("round_fine_rings", 9), ("round_candidates", -1), ("round_levels", 2.0),
                         ("surface_target", "TEXELS"), ("round_resolution", "HALF")):
        with pytest.raises(core_settings.SettingsError):
            core_settings.Settings(method="ROUND", **{field: value}).validate()
    assert core_settings.Settings(method="JUMPMAP", round_levels=0).validate() is not None  # not used there


def test_smallest_sample_side_is_what_the_synthesizer_accepts():
    native = pytest.importorskip("texsynth_native")
    positions, triangles, uvs = square(1.0)
    context = native.RoundSynthesisContext(positions, triangles, uvs, width=32, height=32, texels_per_unit=32)
    settings = core_settings.Settings(method="ROUND")
    side = core.smallest_sample_side(settings)
    up = np.tile(np.array([0, 1, 0], np.float32), (4, 1))
    sample = np.random.default_rng(0).random((side, side, 3)).astype(np.float32)
    native.round_synthesize(context, sample, up, seed=1)
    with pytest.raises(ValueError, match="smaller than"):
        native.round_synthesize(context, sample[:side // 2, :side // 2].copy(), up, seed=1)


def test_context_cache_keys_on_geometry_target_and_parameters():
    positions, triangles, uvs = square()
    arrays = core_layers.MeshArrays(positions, np.zeros(0, np.int32), np.zeros(0, np.int32), np.zeros(0, np.int32))
    settings = core_settings.Settings(method="ROUND")
    target = core.SurfaceTarget("IMAGE", 64, 64, 2)
    key = round_core.ContextCache.key(arrays, triangles, uvs, target, 10.0, settings)
    assert key == round_core.ContextCache.key(arrays, triangles, uvs.copy(), target, 10.0, settings)
    moved = core_layers.MeshArrays(positions + 1, arrays.corner_verts, arrays.poly_starts, arrays.poly_sizes)
    others = [round_core.ContextCache.key(moved, triangles, uvs, target, 10.0, settings),
              round_core.ContextCache.key(arrays, triangles, uvs * 0.5, target, 10.0, settings),
              round_core.ContextCache.key(arrays, triangles, uvs, core.SurfaceTarget("IMAGE", 128, 128, 2), 10.0, settings),
              round_core.ContextCache.key(arrays, triangles, uvs, target, 11.0, settings),
              round_core.ContextCache.key(arrays, triangles, uvs, target, 10.0, core_settings.Settings(round_levels=2))]
    assert len(set(others + [key])) == 6
    cache = round_core.ContextCache(capacity=2)
    for name in ("a", "b", "c"):
        cache.put(name, name.upper())
    assert (cache.get("a"), cache.get("b"), cache.get("c")) == (None, "B", "C")


class _FlatExemplarEstimate:
    """A stand-in for the module's sample-analysis estimate: 100 MB whatever the level."""

    @staticmethod
    def estimate_patch_exemplar_bytes(width, height, channels, patch, tileable=False):
        return 100e6


def test_patch_memory_advice_names_only_changes_that_apply_and_an_image_size_that_fits():
    module, levels = _FlatExemplarEstimate(), [(512, 512, 32)]
    target = core.SurfaceTarget("IMAGE", 4096, 4096, 4)
    samples, surface_pixels = 4096 * 4096, 16e6
    settings = core_settings.Settings(method="PATCHES", patch_mode="SAMPLING", patch_size=32)
    needed = patches_core.estimate_patch_megabytes(module, samples, "SAMPLING", levels, surface_pixels, 4, False)
    assert needed > patches_core.PATCH_MAX_MEGABYTES
    advice = patches_core.memory_advice(module, settings, target, samples, levels, surface_pixels, 4, 1.0, (512, 512))
    size = int(re.search(r"an image of (\d+) px \(Size, CLI --bake-size \1\)", advice).group(1))
    fits = patches_core.estimate_patch_megabytes(module, samples * (size / 4096) ** 2, "SAMPLING", levels,
                                                 surface_pixels, 4, False)
    bigger = patches_core.estimate_patch_megabytes(module, samples * ((size + 64) / 4096) ** 2, "SAMPLING", levels,
                                                   surface_pixels, 4, False)
    assert fits <= patches_core.PATCH_MAX_MEGABYTES < bigger, (size, fits, bigger)
    assert "Sampling mode" not in advice and "larger patches" in advice, advice  # already sampling
    optimisation = core_settings.Settings(method="PATCHES", patch_mode="OPTIMISATION", patch_size=64)
    advice = patches_core.memory_advice(module, optimisation, core.SurfaceTarget("VERTICES"), samples, levels,
                                        surface_pixels, 4, 1.0, (512, 512))
    assert "Patch Sampling mode (CLI --mode sampling)" in advice and "image" not in advice, advice
    assert "larger patches" not in advice, advice  # 64 is the largest patch size


def test_a_working_sample_over_the_memory_limit_is_reduced_to_the_largest_that_fits():
    """Match Target: a sample whose analysis would pass the limit is reduced step by step, and the first
    step that fits is taken (the corpus' 1024-2048 px photos were refused on the bunny). Full Sample keeps the
    sample, and the caller refuses."""
    native = pytest.importorskip("texsynth_native")
    import types
    side = 1024  # its analysis with 32 px patches: about 2 GB, over PATCH_EXEMPLAR_MAX_MEGABYTES
    sample = np.random.default_rng(3).random((side, side, 3)).astype(np.float32)
    positions = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], np.float32)
    triangles = np.array([[0, 1, 2], [0, 2, 3]], np.int32)
    mesh = types.SimpleNamespace(positions=positions, scale_multiplier=None)
    settings = core_settings.Settings(method="PATCHES", patch_mode="SAMPLING", patch_size=32)
    samples = 200000
    whole = patches_core.MemoryPlan(native, sample, float(side), settings, samples, mesh, triangles)
    assert not whole.fits() and whole.exemplar_megabytes > patches_core.PATCH_EXEMPLAR_MAX_MEGABYTES
    reduced, texels, plan = patches_core.fit_to_memory(native, sample, float(side), settings, samples, mesh,
                                                       triangles)
    assert plan.fits() and reduced.shape[1] < side and reduced.shape[0] == reduced.shape[1], reduced.shape
    assert texels == pytest.approx(side * reduced.shape[1] / float(side))  # the same world size
    # The largest that fits: the step before it did not.
    step = round(np.log(reduced.shape[1] / side) / np.log(patches_core.MEMORY_FIT_STEP))
    larger = int(round(side * patches_core.MEMORY_FIT_STEP ** (step - 1)))
    bigger = core.working_sample(sample, float(side), float(larger), "AUTO")[0]
    assert not patches_core.MemoryPlan(native, bigger, float(larger), settings, samples, mesh, triangles).fits()
    # Area averages of the sample, not a crop: the mean colour stays.
    assert np.allclose(reduced.mean(axis=(0, 1)), sample.mean(axis=(0, 1)), atol=1e-3)
    full = core_settings.Settings(method="PATCHES", patch_mode="SAMPLING", patch_size=32, round_resolution="FULL")
    kept, _, plan = patches_core.fit_to_memory(native, sample, float(side), full, samples, mesh, triangles)
    assert kept is sample and not plan.fits()


def test_an_exemplar_saved_with_other_parameters_is_not_reused(tmp_path):
    native = pytest.importorskip("texsynth_native")
    addon_native = addon_package.load("native")
    addon_native._module, addon_native._reason, addon_native._tried = native, None, True  # one copy of the module
    sample = np.random.default_rng(8).random((40, 40, 3)).astype(np.float32)
    exemplar, how = patches_core.ExemplarCache().get(sample, 16, False, str(tmp_path))
    assert how == "built"
    (path,) = tmp_path.glob("patches-*.tsx")
    assert patches_core.ExemplarCache().get(sample, 16, False, str(tmp_path))[1] == "disk"
    # Files under the same name made with another patch size, seed or tiling, or from other pixels:
    # each is refused by its stored key and rebuilt, never used.
    for other in (native.patch_exemplar(sample, patch_size=8), native.patch_exemplar(sample, patch_size=16, seed=3),
                  native.patch_exemplar(sample, patch_size=16, tileable=True),
                  native.patch_exemplar(sample[::-1].copy(), patch_size=16)):
        other.save(str(path))
        rebuilt, how = patches_core.ExemplarCache().get(sample, 16, False, str(tmp_path))
        assert how == "built" and rebuilt.key == exemplar.key != other.key
        assert native.load_patch_exemplar(str(path)).key == exemplar.key  # written over the stale file
    # Every parameter is in the file name too: another patch size or tiling has its own file.
    patches_core.ExemplarCache().get(sample, 8, False, str(tmp_path))
    patches_core.ExemplarCache().get(sample, 16, True, str(tmp_path))
    assert len(list(tmp_path.glob("patches-*.tsx"))) == 3
