# SPDX-License-Identifier: GPL-3.0-or-later
"""Node groups and materials that show TexSynth results in Eevee and Cycles."""
