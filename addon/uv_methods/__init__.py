# SPDX-License-Identifier: GPL-3.0-or-later
"""Jump maps and texton strings: coordinates into the original sample plus blend data."""
