# SPDX-License-Identifier: GPL-3.0-or-later
"""bpy-free core: settings, reports, the native calls and what is computed around them."""
