# SPDX-License-Identifier: GPL-3.0-or-later
"""Surface-colour methods: a colour per surface sample (image texels through a UV map, or vertices)."""
