# SPDX-License-Identifier: GPL-3.0-or-later
"""What the command line (texsynth_cli.py) does inside Blender once the add-on is loaded."""
