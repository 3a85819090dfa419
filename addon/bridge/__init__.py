# SPDX-License-Identifier: GPL-3.0-or-later
"""All bpy mesh I/O (foreach_get/foreach_set on numpy arrays): the one place that touches mesh data."""
