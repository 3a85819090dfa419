# SPDX-License-Identifier: GPL-3.0-or-later
"""Where the tests' shared files are, for tests in any subfolder of python_tests/ (conftest.py puts this folder
on sys.path)."""
import os

TESTS = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(TESTS)
ADDON = os.path.join(ROOT, "addon")
SAMPLES = os.path.join(ROOT, "blend_samples")
BENCH = os.path.join(TESTS, "bench")
HOSTILE = os.path.join(TESTS, "hostile")          # the hostile corpus and its runners
BLENDER_SCRIPTS = os.path.join(TESTS, "blender")  # scripts run inside `blender -b`, beside their pytest launchers
INSTALL_SCRIPTS = os.path.join(TESTS, "install")
IMAGE_SEEDS = os.path.join(TESTS, "image_headers", "seeds")
