# SPDX-License-Identifier: GPL-3.0-or-later
"""Shared pytest setup: make addon/ importable (texsynth_native and the bpy-free core)."""
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ADDON_DIR = os.path.join(ROOT, "addon")
if ADDON_DIR not in sys.path:
    sys.path.insert(0, ADDON_DIR)
