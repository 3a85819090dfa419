# SPDX-License-Identifier: GPL-3.0-or-later
"""Native error messages reworded for the interface they are read in (bpy-free).

texsynth_native names its own arguments: `scale` in texels per unit (the CLI's and the panel's Scale is the
sample's world size, the inverse) and `allow_oversized=True`. Settings.interface says who reads the message:
API (core/settings.Settings in a script), PANEL (the add-on's properties) or CLI (texsynth_cli.py).
"""
import contextlib
import math
import re

INTERFACES = ("API", "PANEL", "CLI")
# (the sample's world size, the switch that maps oversized faces anyway) as each interface names them.
NAMES = {"API": ("sample_world_size", "set allow_oversized=True"),
         "PANEL": ("Scale", "enable Allow Oversized Faces"),
         "CLI": ("--scale", "pass --allow-oversized")}

# native/include/texsynth/synth/face_frame.hpp, check_oversized_faces.
_OVERSIZED = re.compile(r"(?P<count>\d+) of (?P<faces>\d+) faces are larger than the (?P<size>\d+x\d+) sample at "
                        r"scale (?P<texels>[0-9.eE+-]+) texels/unit \(worst face (?P<ratio>[0-9.eE+-]+)x the "
                        r"sample\);.*?allow_oversized=True", re.DOTALL)
# native/src/synth/jumpmap_synth.cpp: refused even with allow_oversized.
_HUGE = re.compile(r"scale (?P<texels>[0-9.eE+-]+) makes face (?P<face>\d+) span more than 1e9 texels")


def world_size_that_fits(world_size, ratio):
    """The smallest 3-significant-digit world size at least world_size x ratio, a little above it: the
    printed ratio is rounded and a face exactly the sample's size would still be refused."""
    needed = float(world_size) * float(ratio) * (1.0 + 1e-4)
    step = 10.0 ** (math.floor(math.log10(needed)) - 2)
    return math.ceil(needed / step) * step


def _number(value):
    return "%.6g" % value


def for_interface(message, interface, world_size):
    """`message` with the native oversized-face advice in `interface`'s terms (unchanged if it has none).
    world_size: the sample's world size of the run (Settings.sample_world_size)."""
    scale_name, switch = NAMES.get(interface, NAMES["API"])

    def oversized(match):
        ratio = float(match["ratio"])
        return ("%s of %s faces are larger than the %s sample at %s %s (worst face %sx the sample); raise %s to "
                "at least %s, subdivide those faces, or %s"
                % (match["count"], match["faces"], match["size"], scale_name, _number(world_size), match["ratio"],
                   scale_name, _number(world_size_that_fits(world_size, ratio)), switch))

    def huge(match):
        return "%s %s makes face %s span more than 1e9 texels (raise %s)" % (
            scale_name, _number(world_size), match["face"], scale_name)

    text, matched = _OVERSIZED.subn(oversized, message)
    text = _HUGE.sub(huge, text)
    if not matched and "allow_oversized=True" in text:  # native wording changed: still name this switch
        text = text.replace("lower the scale", "raise %s" % scale_name)
        text = re.sub(r"(?:pass )?allow_oversized=True", switch, text)
    return text


@contextlib.contextmanager
def reworded_for(settings, error_type):
    """Re-raises a native ValueError as error_type with its message in settings.interface's terms."""
    try:
        yield
    except ValueError as error:
        text = for_interface(str(error), settings.interface, settings.sample_world_size)
        if text == str(error):
            raise
        raise error_type(text) from error
