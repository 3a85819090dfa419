# SPDX-License-Identifier: GPL-3.0-or-later
"""Scene properties, operators and sidebar panels."""
