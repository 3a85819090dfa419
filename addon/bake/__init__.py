# SPDX-License-Identifier: GPL-3.0-or-later
"""Bake: a TexSynth result into one image through a chosen UV map (options.py bpy-free, baking.py bpy)."""
