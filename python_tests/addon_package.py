# SPDX-License-Identifier: GPL-3.0-or-later
"""Imports the add-on's bpy-free modules outside Blender: registers addon/ as package `texsynth`
without running its __init__.py (which needs bpy)."""
import functools
import importlib
import os
import re
import subprocess
import sys
import types

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ADDON_DIR = os.path.join(ROOT, "addon")
BLENDER = os.environ.get("TEXSYNTH_BLENDER", "blender")


def load(submodule):
    if "texsynth" not in sys.modules:
        package = types.ModuleType("texsynth")
        package.__path__ = [ADDON_DIR]
        sys.modules["texsynth"] = package
        importlib.import_module("texsynth.methods")  # registers the methods, as the add-on's ui/ does
    return importlib.import_module("texsynth." + submodule)


def real_synthesizer_available():
    """True when the built texsynth_native implements the jump-map synthesizer."""
    try:
        import texsynth_native
    except ImportError:
        return False
    return hasattr(texsynth_native, "synthesize_jumpmap") and hasattr(texsynth_native, "preprocess")


@functools.lru_cache(maxsize=None)
def blender_version():
    """(major, minor, patch) of the Blender the tests run (TEXSYNTH_BLENDER), from `blender --version`."""
    output = subprocess.run([BLENDER, "--version"], capture_output=True, text=True, timeout=120).stdout
    match = re.search(r"^Blender (\d+)\.(\d+)\.(\d+)", output, re.MULTILINE)
    if not match:
        raise RuntimeError("could not read the version of %r from: %s" % (BLENDER, output[:500]))
    return tuple(int(part) for part in match.groups())
