# SPDX-License-Identifier: GPL-3.0-or-later
"""bpy-free core of the add-on (addon/core/, addon/uv_methods/core.py and encoding.py, addon/native.py), under plain pytest."""

import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

import addon_package
import paths

finite = addon_package.load("core.finite")
core_layers = addon_package.load("core.layers")
reporting = addon_package.load("core.reporting")
sample_image = addon_package.load("core.sample_image")
core_settings = addon_package.load("core.settings")
uv_core = addon_package.load("uv_methods.core")
encoding = addon_package.load("uv_methods.encoding")
native = addon_package.load("native")


def test_valid_settings_pass_and_each_bad_setting_is_named():
    assert core_settings.Settings().validate() is not None
    bad = {"method": ("NOPE", "method"), "sample_world_size": (0.0, "scale"), "seed": (-1, "seed"),
           "jump_rate": (float("nan"), "jump rate"), "orientation": ("UP", "orientation"),
           "axis": ((0.0, 0.0, 0.0), "axis"), "neighbourhood": (4, "neighbourhood"),
           "blend_threshold": (-0.5, "blend threshold"), "blend_mode": ("SOFT", "blend mode")}
    for field, (value, word) in bad.items():
        with pytest.raises(core_settings.SettingsError, match=word):
            core_settings.Settings(**{field: value}).validate()
    assert core_settings.Settings(method="TEXTON", blend_threshold=2.0).validate() is not None
    with pytest.raises(core_settings.SettingsError, match="attribute"):
        core_settings.Settings(orientation="FIELD").validate()
    for inf in (float("inf"), -1.0, True):
        with pytest.raises(core_settings.SettingsError):
            core_settings.Settings(sample_world_size=inf).validate()


def test_auto_blend_mode_is_histogram_for_jump_maps_and_linear_for_texton():
    assert core_settings.Settings().blend_mode == "AUTO"
    assert core_settings.Settings(method="JUMPMAP").resolved_blend_mode() == "HISTOGRAM"
    assert core_settings.Settings(method="TEXTON").resolved_blend_mode() == "LINEAR"
    assert core_settings.Settings(method="TEXTON", blend_mode="VARIANCE").resolved_blend_mode() == "VARIANCE"


def test_texels_per_unit_is_width_over_world_size():
    # A 256-texel sample spanning 2 world units puts 128 texels on each unit.
    assert core_settings.texels_per_unit(256, 2.0) == 128.0
    assert core_settings.texels_per_unit(100, 0.5) == 200.0
    for width, size in ((0, 1.0), (256, 0.0), (256, float("inf")), (256, -3.0)):
        with pytest.raises(core_settings.SettingsError):
            core_settings.texels_per_unit(width, size)


def test_object_seed_is_stable_distinct_and_in_range():
    assert core_settings.object_seed(5, "Cube") == core_settings.object_seed(5, "Cube")
    seeds = {core_settings.object_seed(s, n) for s in range(4) for n in ("Cube", "Sphere", "Suzanne")}
    assert len(seeds) == 12
    assert all(0 <= s < 2 ** 63 for s in seeds)


def test_one_uv_map_capacity_and_legacy_names():
    assert core_layers.is_texsynth_uv_name("TexSynth") and core_layers.is_texsynth_uv_name("TexSynth_B2")  # 0.1 layers
    assert not core_layers.is_texsynth_uv_name("TexSynth_Bx") and not core_layers.is_texsynth_uv_name("UVMap")
    # TexSynth needs one UV map: 7 foreign ones leave room, and its own (older ones too) are replaced.
    core_layers.check_uv_capacity(["U%d" % k for k in range(7)])
    core_layers.check_uv_capacity(["U%d" % k for k in range(3)] + ["TexSynth"] + ["TexSynth_B%d" % k for k in range(4)])
    with pytest.raises(core_settings.SettingsError, match="at most 8"):
        core_layers.check_uv_capacity(["U%d" % k for k in range(8)])


def test_blend_set_rgba_packs_two_sets_per_attribute():
    result = _result(5, 4)
    result["blend_uv"] = np.arange(4 * 5 * 2, dtype=np.float32).reshape(4, 5, 2)
    first, second = (b.reshape(5, 4) for b in encoding.blend_set_rgba(result, 5))
    corner = 3
    assert list(first[corner]) == list(result["blend_uv"][0, corner]) + list(result["blend_uv"][1, corner])
    assert list(second[corner]) == list(result["blend_uv"][2, corner]) + list(result["blend_uv"][3, corner])
    three = _result(5, 3)
    three["blend_uv"] += 7.0
    first, second = (b.reshape(5, 4) for b in encoding.blend_set_rgba(three, 5))
    assert np.all(first == 7.0) and np.all(second[:, :2] == 7.0) and np.all(second[:, 2:] == 0.0)


def test_blend_set_rgba_uses_packed_native_pairs_without_copying():
    result = _result(5, 4)
    result["blend_set_pairs"] = np.arange(2 * 5 * 4, dtype=np.float32).reshape(2, 5, 4)
    first, second = encoding.blend_set_rgba(result, 5)
    assert np.shares_memory(first, result["blend_set_pairs"]) and np.shares_memory(second, result["blend_set_pairs"])
    assert list(second[:4]) == [20.0, 21.0, 22.0, 23.0]
    encoding.check_result(result, 5)  # shapes of the packed form are accepted
    result["blend_set_pairs"] = result["blend_set_pairs"][:, :, :2].copy()
    with pytest.raises(core_settings.SettingsError, match="blend_set_pairs"):
        encoding.check_result(result, 5)


def test_shader_mean_decodes_srgb_like_blender():
    pixels = np.full((2, 3, 4), 0.5, np.float32)
    pixels[..., 3] = 0.25  # alpha is not colour
    assert sample_image.shader_mean(pixels, srgb=False) == (0.5, 0.5, 0.5)
    # sRGB 0.5 is linear 0.2140 (the sRGB curve: ((0.5 + 0.055) / 1.055) ** 2.4).
    assert np.allclose(sample_image.shader_mean(pixels, srgb=True), 0.21404, atol=1e-4)
    assert np.isclose(sample_image.srgb_to_linear(0.02), 0.02 / 12.92)
    grey = np.zeros((2, 2, 1), np.float32)
    grey[0, 0, 0] = 1.0
    assert sample_image.shader_mean(grey, srgb=False) == (0.25, 0.25, 0.25)


def test_shader_mean_in_row_chunks_matches_one_float64_pass():
    # 300 rows in chunks of 128 (the last one partial), both sides of the sRGB curve's linear toe.
    pixels = np.random.RandomState(4).rand(300, 70, 3).astype(np.float32) ** 3
    for srgb in (False, True):
        reference = (sample_image.srgb_to_linear(pixels) if srgb else pixels.astype(np.float64)).mean(axis=(0, 1))
        assert np.allclose(sample_image.shader_mean(pixels, srgb, rows_per_chunk=128), reference, rtol=1e-6)
        assert np.allclose(sample_image.shader_mean(pixels, srgb, rows_per_chunk=7), reference, rtol=1e-6)


def test_blender_pixels_are_flipped_top_row_first():
    width, height = 3, 2
    bottom_up = np.arange(width * height * 4, dtype=np.float32)
    image = sample_image.blender_pixels_to_image(bottom_up, width, height, 4)
    assert image.shape == (2, 3, 4) and image.flags.c_contiguous and image.dtype == np.float32
    # Blender's first row is the bottom one, so it becomes the last row.
    assert np.array_equal(image[1, 0], [0, 1, 2, 3]) and np.array_equal(image[0, 2], [20, 21, 22, 23])
    with pytest.raises(core_settings.SettingsError, match="expected"):
        sample_image.blender_pixels_to_image(bottom_up[:-1], width, height, 4)
    bad = bottom_up.copy()
    bad[5] = np.nan
    with pytest.raises(core_settings.SettingsError, match="NaN"):
        sample_image.blender_pixels_to_image(bad, width, height, 4)


def _result(corners, sets):
    return {"base_uv": np.zeros((corners, 2), np.float32), "num_blend_sets": sets,
            "blend_uv": np.zeros((sets, corners, 2), np.float32),
            "blend_weights": np.eye(max(sets, 1), dtype=np.float32)[np.arange(corners) % max(sets, 1)][:, :sets]}


def test_check_result_rejects_wrong_shapes_types_and_nan():
    encoding.check_result(_result(6, 4), 6)
    encoding.check_result(_result(6, 0), 6)
    with pytest.raises(core_settings.SettingsError, match="base_uv"):
        encoding.check_result(_result(6, 4), 7)
    wrong_dtype = _result(6, 3)
    wrong_dtype["blend_uv"] = wrong_dtype["blend_uv"].astype(np.float64)
    with pytest.raises(core_settings.SettingsError, match="blend_uv"):
        encoding.check_result(wrong_dtype, 6)
    with_nan = _result(6, 3)
    with_nan["blend_weights"][2, 1] = np.nan
    with pytest.raises(core_settings.SettingsError, match="NaN"):
        encoding.check_result(with_nan, 6)
    with pytest.raises(core_settings.SettingsError, match="blend sets"):
        encoding.check_result(_result(6, 5), 6)
    for bad in (np.inf, -np.inf):
        with_inf = _result(6, 4)
        with_inf["base_uv"][5, 0] = bad
        with pytest.raises(core_settings.SettingsError, match="base_uv contains NaN or infinite"):
            encoding.check_result(with_inf, 6)


def test_all_finite_sees_nan_and_inf_anywhere():
    values = np.zeros((7, 3), np.float32)
    assert finite.all_finite(values) and finite.all_finite(np.zeros((0, 2), np.float32))
    for index in [(0, 0), (3, 1), (6, 2)]:
        for bad in (np.nan, np.inf, -np.inf):
            broken = values.copy()
            broken[index] = bad
            assert not finite.all_finite(broken), (index, bad)


def test_all_finite_is_exact_when_a_sum_of_finite_values_overflows():
    huge = np.full(1000, 3e38, np.float32)  # finite, but their sum is inf in float32
    with np.errstate(over="ignore"):
        assert np.isinf(np.add.reduce(huge))
    assert finite.all_finite(huge)
    huge[500] = np.nan
    assert not finite.all_finite(huge)
    opposite = np.array([np.inf, -np.inf, 1.0], np.float32)  # the sum is NaN
    assert not finite.all_finite(opposite)


def test_finite_scan_names_the_first_bad_array_and_reraises_errors():
    good, bad = np.zeros(10, np.float32), np.zeros(10, np.float32)
    bad[3] = np.inf
    assert finite.FiniteScan([("a", good), ("b", good)]).wait() is None
    assert finite.FiniteScan([("a", good), ("b", bad), ("c", bad)]).wait() == "b"
    with pytest.raises(AttributeError):  # the worker's error reaches the caller
        finite.FiniteScan([("a", None)]).wait()


def test_weights_rgba_stores_w0_w1_w2_and_one_minus_w3():
    three = _result(5, 3)
    rgba = encoding.weights_rgba(three, 5).reshape(5, 4)
    assert np.array_equal(rgba[:, :3], three["blend_weights"]) and np.all(rgba[:, 3] == 1)
    four = _result(6, 4)  # corners 3 of each 4 carry w3 = 1
    rgba = encoding.weights_rgba(four, 6).reshape(6, 4)
    assert np.array_equal(rgba[:, :3], four["blend_weights"][:, :3])
    assert np.array_equal(rgba[:, 3], [1, 1, 1, 0, 1, 1])
    # consume=True: the same buffer, converted in place and taken out of the result.
    consumed = _result(6, 4)
    source = consumed["blend_weights"]
    in_place = encoding.weights_rgba(consumed, 6, consume=True)
    assert np.array_equal(in_place, rgba.ravel()) and np.shares_memory(in_place, source)
    assert consumed["blend_weights"] is None
    # Without weights the buffer reads like a missing attribute: (0, 0, 0, 1).
    assert np.array_equal(encoding.weights_rgba(_result(5, 0), 5).reshape(5, 4), np.tile([0, 0, 0, 1], (5, 1)))


def test_load_sample_checks_paths_and_arrays(tmp_path):
    with pytest.raises(core_settings.SettingsError, match="no sample"):
        sample_image.load_sample("")
    with pytest.raises(core_settings.SettingsError, match="not found"):
        sample_image.load_sample(str(tmp_path / "missing.png"))
    with pytest.raises(core_settings.SettingsError, match="H x W x C"):
        sample_image.load_sample(np.zeros((4, 4), np.float32))
    assert sample_image.load_sample(np.zeros((4, 4, 3), np.float64)).dtype == np.float32
    assert sample_image.load_sample(np.zeros((4, 4, 3), np.uint8)).dtype == np.uint8


def test_report_summary_and_json():
    report = reporting.Report()
    arrays = core_layers.MeshArrays(np.zeros((4, 3), np.float32), np.zeros(8, np.int32),
                                 np.array([0, 4], np.int32), np.array([4, 4], np.int32))
    report.add_object("A", arrays, {"jumps": 3})
    report.failures.append(("B", "mesh has no faces"))
    report.seconds = {"preprocess": 0.5, "synthesis": 1.0, "transfer": 0.25, "total": 2.0}
    data = report.as_json()
    assert (data["faces"], data["vertices"], data["corners"]) == (2, 4, 8)
    assert data["failures"] == [{"object": "B", "error": "mesh has no faces"}]
    assert "1 object(s), 2 faces in 2.00 s" in report.summary() and "B: mesh has no faces" in report.summary()
    empty = reporting.Report(failures=[("C", "bad")])
    assert empty.summary() == "TexSynth: nothing written; C: bad"


def test_timings_accumulate_per_phase():
    timings = reporting.Timings()
    for phase in ("read", "write", "write"):
        with timings.phase(phase):
            sum(range(1000))
    seconds = timings.as_dict()
    assert seconds["read"] > 0 and seconds["write"] > 0 and seconds["synthesis"] == 0.0
    assert seconds["transfer"] == seconds["read"] + seconds["write"]
    assert seconds["total"] >= seconds["transfer"]


def test_native_diagnosis_names_the_problem(tmp_path):
    suffix = ".cpython-311-x86_64-linux-gnu.so"
    assert "missing" in native.diagnose(str(tmp_path), suffix, (3, 11))
    (tmp_path / "texsynth_native.cpython-310-x86_64-linux-gnu.so").write_bytes(b"")
    message = native.diagnose(str(tmp_path), suffix, (3, 11))
    assert "another Python" in message and "cpython-310" in message and "3.11" in message
    (tmp_path / ("texsynth_native" + suffix)).write_bytes(b"")
    assert native.diagnose(str(tmp_path), suffix, (3, 11)) is None


@pytest.mark.parametrize("filename, needs", [
    ("texsynth_native.cpython-313-x86_64-linux-gnu.so", "Python 3.13 on Linux"),
    ("texsynth_native.cp311-win_amd64.pyd", "Python 3.11 on Windows"),
    ("texsynth_native.cpython-311-darwin.so", "Python 3.11 on macOS"),
])
def test_a_package_for_another_python_or_platform_names_both(tmp_path, filename, needs):
    """Issue 31: the sidebar, the console and the CLI say which Python and platform the package was built for
    and which this Blender runs."""
    (tmp_path / filename).write_bytes(b"")
    message = native.diagnose(str(tmp_path), ".cpython-311-x86_64-linux-gnu.so", (3, 11), "linux")
    assert "built for %s (%s)" % (needs, filename) in message, message
    assert "runs Python 3.11 on Linux" in message and "\n" not in message


def test_a_package_missing_one_of_its_libraries_names_the_file(tmp_path):
    (tmp_path / "texsynth_native.libs").mkdir()
    message = native.explain_load_error(ImportError(
        "libtbb-0a1b2c3d.so.2: cannot open shared object file: No such file or directory"), str(tmp_path))
    assert "damaged" in message and "texsynth_native.libs/libtbb-0a1b2c3d.so.2" in message, message


def test_load_errors_are_explained_in_one_line():
    missing = native.explain_load_error(ImportError(
        "libOpenImageIO.so.2.5: cannot open shared object file: No such file or directory"))
    assert "libOpenImageIO.so.2.5" in missing and "does not have" in missing and "\n" not in missing
    symbol = native.explain_load_error(ImportError("/x/texsynth_native.so: undefined symbol: _ZN4OIIO8geterrorB5cxx11Eb"))
    assert "undefined symbol _ZN4OIIO8geterrorB5cxx11Eb" in symbol and "other versions" in symbol
    assert native.explain_load_error(OSError("weird")) == "native module failed to load: weird"


@pytest.mark.skipif(shutil.which("cc") is None, reason="needs a C compiler to make a module with a missing library")
def test_reason_names_the_missing_shared_library_of_a_real_module(tmp_path):
    """A module file that links a library the system lacks: the reason names that library."""
    import sysconfig
    (tmp_path / "dep.c").write_text("int texsynth_probe_dep(void) { return 1; }\n")
    (tmp_path / "mod.c").write_text("int texsynth_probe_dep(void);\nint PyInit_texsynth_native(void) "
                                    "{ return texsynth_probe_dep(); }\n")
    run = dict(cwd=tmp_path, check=True, capture_output=True)
    subprocess.run(["cc", "-shared", "-fPIC", "-o", "libtexsynth_probe_dep.so", "dep.c"], **run)
    module = "texsynth_native" + sysconfig.get_config_var("EXT_SUFFIX")
    subprocess.run(["cc", "-shared", "-fPIC", "-o", module, "mod.c", "-L.", "-ltexsynth_probe_dep"], **run)
    os.remove(tmp_path / "libtexsynth_probe_dep.so")
    script = "import addon_package; print('REASON', addon_package.load('native').reason())"
    process = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=600,
                             cwd=paths.TESTS,
                             env=dict(os.environ, TEXSYNTH_MODULE_DIR=str(tmp_path),
                                      PYTHONPATH=paths.TESTS))
    assert process.returncode == 0, process.stderr
    assert "REASON native module needs the shared library libtexsynth_probe_dep.so" in process.stdout, process.stdout


@pytest.fixture
def real_native(monkeypatch):
    """The built module as add-on's native module (imported once, under its own name: loading the same
    extension a second time as texsynth.texsynth_native would register its types twice)."""
    module = pytest.importorskip("texsynth_native")
    if not hasattr(module, "synthesize_texton"):
        pytest.skip("texsynth_native without synthesize_texton")
    monkeypatch.setattr(native, "_module", module)
    monkeypatch.setattr(native, "_tried", True)
    return module


def test_texton_method_calls_the_native_texton_synthesizer_and_returns_corner_attributes(real_native):
    rng = np.random.default_rng(0)
    image = rng.random((32, 32, 3), dtype=np.float32)
    pre = real_native.preprocess(image, jump_candidates=2)
    ys, xs = np.mgrid[0:5, 0:5]
    pos = np.stack([xs.ravel(), ys.ravel(), np.zeros(25)], 1).astype(np.float32) * 0.1
    quads = [[y * 5 + x, y * 5 + x + 1, y * 5 + x + 6, y * 5 + x + 5] for y in range(4) for x in range(4)]
    arrays = core_layers.MeshArrays(pos, np.array(sum(quads, []), np.int32), np.arange(0, 64, 4, dtype=np.int32),
                                 np.full(16, 4, np.int32))
    settings = core_settings.Settings(method="TEXTON").validate()
    with pytest.raises(core_settings.SettingsError, match="pixels"):
        uv_core.synthesize(pre, arrays, settings, 1, 60.0)
    result = uv_core.synthesize(pre, arrays, settings, 1, 60.0, pixels=image)
    extras = encoding.corner_attributes(result, 64)
    assert set(extras) == {core_layers.EDGE_BLENDED_NAME, core_layers.EDGE_ERROR_NAME}
    blended = extras[core_layers.EDGE_BLENDED_NAME]
    # Each of the 4 x 4 quads' 4 edges: interior edges are blended (every corner but the boundary ones).
    assert blended.sum() == 64 - 16 and set(np.unique(blended)) <= {0.0, 1.0}
    np.testing.assert_array_equal(encoding.check_result(result, 64), result["base_uv"])
    threshold = core_settings.Settings(method="TEXTON", blend_threshold=1.0).validate()
    with pytest.raises(core_settings.SettingsError, match="camera"):
        uv_core.synthesize(pre, arrays, threshold, 1, 60.0, pixels=image)
    far = uv_core.synthesize(pre, arrays, threshold, 1, 60.0, pixels=image,
                              view=uv_core.View(position=(0.2, 0.2, 1e6), pixels_per_radian=1000.0))
    assert far["stats"]["blended_edges"] == 0  # a far camera: every Φ is tiny


def _blurred_noise(sigma, size=256, seed=0):
    """White noise blurred by a Gaussian of std sigma (circular): its autocorrelation is a Gaussian of
    std sigma * sqrt(2), so its correlation length is known without looking at the code."""
    noise = np.random.RandomState(seed).rand(size, size, 3)
    frequencies = np.fft.fftfreq(size)
    kernel = np.exp(-2 * (np.pi * sigma) ** 2 * (frequencies[:, None] ** 2 + frequencies[None, :] ** 2))
    return np.stack([np.real(np.fft.ifft2(np.fft.fft2(noise[:, :, c]) * kernel)) for c in range(3)], axis=2)


def test_correlation_length_of_blurred_noise_is_sigma_sqrt2():
    for sigma in (2.0, 4.0, 7.0):
        assert abs(sample_image.correlation_length(_blurred_noise(sigma)) - sigma * np.sqrt(2)) < 0.05 * sigma
    assert sample_image.correlation_length(np.random.RandomState(1).rand(64, 64, 1)) < 1.0  # white noise
    assert sample_image.correlation_length(np.ones((16, 16, 4))) == 1.0  # constant: no NaN


def test_blend_shading_falls_back_to_variance_for_flat_samples(tmp_path, real_native):
    flat = np.zeros((32, 32, 3), np.float32)
    flat[:, :, 0] = 0.25
    flat[::2, :, 1] = 1.0  # two values only
    shading = uv_core.blend_shading(flat, core_settings.Settings(), str(tmp_path), srgb=False)
    assert shading.mode == "VARIANCE" and shading.files is None
    assert "channel 0 is constant" in shading.note and "variance-preserving" in shading.note
    assert np.allclose(shading.mean, (0.25, 0.5, 0.0)) and np.isfinite(shading.correlation_length)
    # Read as sRGB by Blender: the mean of the decoded values (0.25 -> 0.0508, 1 -> 1, 0 -> 0).
    assert np.allclose(shading.with_colour_space(True).mean, (0.05087, 0.5, 0.0), atol=1e-4)
    textured = _blurred_noise(3.0, 64).astype(np.float32)
    shading = uv_core.blend_shading(textured, core_settings.Settings(), str(tmp_path), srgb=False)
    assert shading.mode == "HISTOGRAM" and shading.note == "" and os.path.isfile(shading.files.lut_path)
    assert uv_core.blend_shading(textured, core_settings.Settings(blend=False), str(tmp_path), False).mode == "LINEAR"


def test_blend_shading_above_4096_squared_uses_variance_and_says_why(tmp_path, real_native):
    # 8K samples are analysed through the working size; the Gaussianized copy is not made for them.
    large = np.zeros((4097, 4096, 1), np.uint8)
    large[::3] = 200
    shading = uv_core.blend_shading(large, core_settings.Settings(), str(tmp_path), srgb=False)
    assert shading.mode == "VARIANCE" and shading.files is None
    assert "4096x4097" in shading.note and "variance-preserving" in shading.note
    assert np.allclose(shading.mean, (200.0 * 1366 / 4097 / 255.0,) * 3, atol=1e-4)
    assert os.listdir(tmp_path) == []  # nothing cached for a transform that was not made
    # A path is measured from its header: the same size as the decoded pixels.
    bricks = os.path.join(paths.SAMPLES, "bricks.png")
    height, width = real_native.load_image(bricks).shape[:2]
    assert sample_image.sample_size(bricks) == (width, height)


def _speckles(size=96, seed=2):
    """Dark noise with rare bright dots: a skewed histogram, like moss's highlights."""
    rng = np.random.RandomState(seed)
    image = 0.1 + 0.05 * rng.rand(size, size, 3)
    dots = rng.rand(size, size) < 0.04
    image[dots] = 0.9 + 0.1 * rng.rand(int(dots.sum()), 3)
    return image.astype(np.float32)


def test_interpolation_fidelity_flags_skewed_histograms(tmp_path, real_native):
    """Interpolating a near-Gaussian sample in Gaussianized space is close to an affine change, so it
    keeps the gradient; rare bright dots shrink when interpolated there (half-way between a dot and
    the dark ground sits near the ground's quantiles), so their gradient drops."""
    module = native.require()
    gaussianish = ((_blurred_noise(1.5, 96) - 0.5) * 0.5 + 0.5).astype(np.float32)
    for image, check in ((gaussianish, lambda f: abs(f - 1.0) < 0.03), (_speckles(), lambda f: f < 0.95)):
        transform = module.histogram_transform(image, cache_dir=str(tmp_path))
        fidelity = uv_core.interpolation_fidelity(image, transform["gaussian"], transform["inverse_lut"])
        assert check(fidelity), fidelity
    # Auto blending avoids the histogram transform for such a sample and says why; asked for, it stays.
    auto = uv_core.blend_shading(_speckles(), core_settings.Settings(), str(tmp_path), srgb=False)
    assert auto.mode == "VARIANCE" and auto.files is None and "Auto" in auto.reason and "%" in auto.reason
    assert auto.note == ""  # a choice, not a warning
    forced = uv_core.blend_shading(_speckles(), core_settings.Settings(blend_mode="HISTOGRAM"), str(tmp_path), srgb=False)
    assert forced.mode == "HISTOGRAM" and forced.note == ""


def test_periodicity_separates_periodic_from_stochastic_samples():
    """A tile repeated 3 x 3 correlates perfectly with itself one tile away (beyond a quarter of the
    width); blurred noise has no correlation that far; a constant sample has none at all."""
    tile = _blurred_noise(2.0, 32, seed=4)
    assert sample_image.periodicity(np.tile(tile, (3, 3, 1))) > 0.99
    assert sample_image.periodicity(_blurred_noise(2.0, 96)) < 0.2
    assert sample_image.periodicity(np.ones((16, 16, 3))) == 0.0


def test_auto_texton_blending_is_linear_for_periodic_and_variance_for_stochastic(tmp_path, real_native):
    settings = core_settings.Settings(method="TEXTON")
    periodic = np.tile(_blurred_noise(2.0, 32, seed=4), (3, 3, 1)).astype(np.float32)
    stochastic = _blurred_noise(2.0, 96).astype(np.float32)
    chosen = {name: uv_core.blend_shading(image, settings, str(tmp_path), srgb=False)
              for name, image in (("periodic", periodic), ("stochastic", stochastic))}
    assert chosen["periodic"].mode == "LINEAR" and "periodic" in chosen["periodic"].reason
    assert chosen["stochastic"].mode == "VARIANCE" and "stochastic" in chosen["stochastic"].reason
    assert all(c.note == "" for c in chosen.values())
    explicit = uv_core.blend_shading(periodic, core_settings.Settings(method="TEXTON", blend_mode="VARIANCE"), str(tmp_path), False)
    assert explicit.mode == "VARIANCE" and explicit.reason == ""


def test_mapping_groups_sum_weights_of_identical_mappings():
    """Two triangles and a quad, hand-made: on polygon 0 set 0 is the polygon's own patch and sets 1, 3
    are one other mapping; on polygon 1 all three used sets differ from the patch and from each other;
    on the quad, four distinct mappings: the fourth shares group 3. Set 2 is unused on triangles."""
    starts, sizes = np.array([0, 3, 6], np.int32), np.array([3, 3, 4], np.int32)
    corners = 10
    base = np.random.RandomState(3).rand(corners, 2).astype(np.float32)
    sets = np.zeros((4, corners, 2), np.float32)
    weights = np.zeros((corners, 4), np.float32)
    # polygon 0: corners 0..2, sets 0, 1, 3 one-hot at its corners
    sets[0, 0:3] = base[0:3]
    sets[1, 0:3] = sets[3, 0:3] = base[0:3] + 0.25
    weights[0:3, [0, 1, 3]] = np.eye(3)
    # polygon 1: three distinct mappings, none the patch
    for k, shift in ((0, 0.1), (1, 0.2), (3, 0.3)):
        sets[k, 3:6] = base[3:6] + shift
    weights[3:6, [0, 1, 3]] = np.eye(3)
    # polygon 2 (quad): four distinct mappings
    for k in range(4):
        sets[k, 6:10] = base[6:10] + 0.1 * (k + 1)
    weights[6:10] = np.eye(4)
    pairs = np.concatenate([sets[0:2].transpose(1, 0, 2).reshape(corners, 4)[None],
                            sets[2:4].transpose(1, 0, 2).reshape(corners, 4)[None]])
    result = dict(base_uv=base, num_blend_sets=4, blend_weights=weights, blend_set_pairs=pairs)
    groups = encoding.mapping_groups_rgba(result, starts, sizes).reshape(corners, 4)
    expected = np.zeros((corners, 4), np.float32)
    expected[0, 0] = 1.0             # set 0 = own patch
    expected[1, 1] = expected[2, 1] = 1.0  # sets 1 and 3: one mapping, group 1
    expected[3, 1], expected[4, 2], expected[5, 3] = 1.0, 1.0, 1.0
    expected[6, 1], expected[7, 2], expected[8, 3], expected[9, 3] = 1.0, 1.0, 1.0, 1.0
    assert np.allclose(groups, expected), groups
    # Inside a polygon the weights interpolate: the groups' totals still sum to the weights' sum.
    assert np.allclose(groups.sum(axis=1), weights.sum(axis=1))
