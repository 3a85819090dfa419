# SPDX-License-Identifier: GPL-3.0-or-later
"""Shared pytest setup for every folder of python_tests/ (native/, core/, blender/, cli/, install/, bench/, docs/).

- addon/ is importable (texsynth_native and the bpy-free core); TEXSYNTH_MODULE_DIR, when set, is searched
  first for texsynth_native (e.g. a sanitizer build).
- This folder is importable too, so tests in any subfolder reach the shared helpers (paths, addon_package,
  blender_run, blender_suite, ...).
- `@pytest.mark.needs_native`: the test needs the real texsynth_native (it is skipped, with the reason, when
  the module is not built for this Python).
"""
import os
import sys

import pytest

TESTS = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, TESTS)
import paths  # noqa: E402

for path in (paths.ADDON, os.environ.get("TEXSYNTH_MODULE_DIR")):
    if path and path not in sys.path:
        sys.path.insert(0, path)


def pytest_configure(config):
    config.addinivalue_line("markers", "needs_native: skipped when texsynth_native is not built for this Python")


def pytest_runtest_setup(item):
    if item.get_closest_marker("needs_native") is None:
        return
    import addon_package
    if not addon_package.real_synthesizer_available():
        pytest.skip("texsynth_native not built")
