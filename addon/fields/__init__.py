# SPDX-License-Identifier: GPL-3.0-or-later
"""Direction and scale fields: bpy-free authoring math, the viewport tools and the overlay."""
