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
