# SPDX-License-Identifier: GPL-3.0-or-later
"""Shared pytest setup: make addon/ importable (texsynth_native and the bpy-free core).

TEXSYNTH_MODULE_DIR, when set, is searched first for texsynth_native (e.g. a sanitizer build).
"""
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ADDON_DIR = os.path.join(ROOT, "addon")
for path in (ADDON_DIR, os.environ.get("TEXSYNTH_MODULE_DIR")):
    if path and path not in sys.path:
        sys.path.insert(0, path)
