# SPDX-License-Identifier: GPL-3.0-or-later
import texsynth_native


def test_module_imports_and_reports_version():
    assert texsynth_native.__version__.count(".") == 2


def test_cache_error_is_a_value_error():
    assert issubclass(texsynth_native.CacheError, ValueError)


def _module_file(name):
    import glob
    import os
    import sysconfig
    folder = os.path.dirname(texsynth_native.__file__)
    return os.path.join(folder, name + sysconfig.get_config_var("EXT_SUFFIX"))


def test_the_module_blender_loads_links_no_image_library():
    """Issue 31: OpenImageIO lives in texsynth_image_io only, so texsynth_native can be bundled for
    blender.org builds without OpenImageIO's few hundred libraries."""
    import subprocess
    needed = subprocess.run(["readelf", "-d", _module_file("texsynth_native")], capture_output=True, text=True,
                            check=True).stdout
    libraries = [line.split("[")[1].rstrip("]") for line in needed.splitlines() if "(NEEDED)" in line]
    assert libraries and not any("OpenImageIO" in name for name in libraries), libraries
    io_needed = subprocess.run(["readelf", "-d", _module_file("texsynth_image_io")], capture_output=True,
                               text=True, check=True).stdout
    assert "libOpenImageIO" in io_needed


def test_without_texsynth_image_io_a_path_is_refused_clearly_and_arrays_still_work(tmp_path):
    """The self-contained package has no texsynth_image_io: a file path must name what is missing and
    what to pass instead; numpy pixels must synthesize as before."""
    import shutil
    import subprocess
    import sys
    shutil.copy(_module_file("texsynth_native"), tmp_path)
    script = """
import numpy as np, texsynth_native as ts
pixels = (np.random.default_rng(1).random((24, 24, 3)) * 255).astype(np.uint8)
print("ARRAY", ts.preprocess(pixels, num_textons=4).width)
for call in (lambda: ts.preprocess("sample.png"), lambda: ts.load_image("sample.png"),
             lambda: ts.image_info("sample.png"), lambda: ts.preprocess(pixels, num_textons=4).write_texton_map_image("t.png")):
    try:
        call()
        print("NO ERROR")
    except ValueError as error:
        print("REFUSED", str(error).replace(chr(10), " "))
"""
    result = subprocess.run([sys.executable, "-c", script], cwd=tmp_path, capture_output=True, text=True,
                            env={"PYTHONPATH": str(tmp_path), "PATH": "/usr/bin:/bin"}, timeout=300)
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert "ARRAY 24" in lines, result.stdout
    refusals = [line for line in lines if line.startswith("REFUSED")]
    assert len(refusals) == 4 and "NO ERROR" not in lines, result.stdout
    for line in refusals:
        assert "texsynth_image_io" in line and "numpy array" in line and "Traceback" not in line, line


def test_image_io_decodes_once_with_the_encoding_of_the_stored_type(tmp_path):
    """texsynth_image_io.decode_image gives load_image's pixels and how they are encoded (integer files sRGB,
    float files linear), which texsynth_native's path arguments take from this one call."""
    import importlib
    import numpy as np
    io = importlib.import_module("texsynth_image_io")
    png = tmp_path / "s.png"
    pixels = (np.arange(6 * 5 * 3) % 256).astype(np.uint8).reshape(6, 5, 3)
    io.write_image_u8(png, pixels)
    decoded, encoding = io.decode_image(png)
    assert encoding == "srgb"
    # OpenImageIO scales by the float reciprocal of 255, not by a division.
    assert np.array_equal(decoded, pixels.astype(np.float32) * (np.float32(1) / np.float32(255)))
    # A float EXR: the cache's Gaussianized sample, written by tinyexr.
    noise = np.random.default_rng(3).random((16, 16, 3), dtype=np.float32)
    exr = texsynth_native.histogram_transform(noise, cache_dir=tmp_path / "cache", lut_size=64)["gaussian_path"]
    decoded, encoding = io.decode_image(exr)
    assert encoding == "linear" and decoded.dtype == np.float32 and decoded.shape == (16, 16, 3)
    # The encoding reaches the native Image: the same EXR as a path and as a linear array agree.
    from_path = texsynth_native.histogram_transform(exr)["gaussian"]
    from_array = texsynth_native.histogram_transform(decoded)["gaussian"]
    assert np.array_equal(from_path, from_array)


def _upstream_version(debian_version):
    """'1:2021.8.0-2' or '3.13.5+dfsg-2' -> the upstream version, as the library itself reports it."""
    import re
    return re.split(r"[+~-]", debian_version.split(":", 1)[-1])[0]


def _package_version_of(path):
    import subprocess
    owner = subprocess.run(["dpkg", "-S", path], capture_output=True, text=True)
    assert owner.returncode == 0, "no Debian package owns %s: %s" % (path, owner.stderr)
    package = owner.stdout.split(": ", 1)[0]  # "libtbb12:amd64"
    version = subprocess.run(["dpkg-query", "-W", "-f", "${Version}", package], capture_output=True, text=True,
                             check=True).stdout
    return package, _upstream_version(version)


def test_build_info_names_the_embree_and_tbb_this_debian_build_links():
    """Issue 31: build_info() asks the Embree device and the TBB runtime that answer; on a Debian build
    they are the system packages' libraries, so their versions must be the packages' versions."""
    import shutil
    import pytest
    info = texsynth_native.build_info()
    if info["self_contained"]:
        pytest.skip("a self-contained build links no Debian packages (test_self_contained_build_info)")
    if not shutil.which("dpkg"):
        pytest.skip("not a Debian system")
    assert info["image_files"] is True and info["compiler"].split()[0] in ("gcc", "clang"), info
    embree_package, embree_version = _package_version_of(info["embree_library"])
    assert embree_package.startswith("libembree") and info["embree_version"] == embree_version, (info, embree_package)
    assert info["embree_header_version"] == info["embree_version"], info
    tbb_package, tbb_version = _package_version_of(info["tbb_library"])
    # oneTBB says "2021.8" for Debian's 2021.8.0.
    same = [int(part) for part in info["tbb_version"].split(".")] + [0] * 3
    assert tbb_package.startswith("libtbb") and same[:3] == [int(part) for part in tbb_version.split(".")][:3], (
        info, tbb_package, tbb_version)
    assert info["tbb_interface_version"] == info["tbb_header_interface_version"], info


def test_self_contained_build_info():
    """The blender.org package: Embree is inside the module, TBB is the bundled copy next to it."""
    import os
    import pytest
    info = texsynth_native.build_info()
    if not info["self_contained"]:
        pytest.skip("a Debian build (test_build_info_names_the_embree_and_tbb_this_debian_build_links)")
    module = os.path.realpath(texsynth_native.__file__)
    assert info["embree_library"] == module and info["embree_version"] == info["embree_header_version"], info
    assert os.path.dirname(info["tbb_library"]) == os.path.join(os.path.dirname(module), "texsynth_native.libs"), info
    assert info["tbb_interface_version"] == info["tbb_header_interface_version"], info
    assert info["image_files"] is False, info
