# SPDX-License-Identifier: GPL-3.0-or-later
"""Names of the data-blocks and nodes TexSynth creates, fitted to Blender's limit.

Blender 3.4 to 4.x cut ID and node names at 63 bytes (5.x allows 255). A cut name no longer matches
the name a later run looks up, so every run created another node group or material ("... (.001").
A name that would not fit keeps its prefix and suffix, shortens the middle and adds a hash of the
whole middle, so it stays unique and the same on every run and every Blender version."""
import hashlib

MAX_NAME_BYTES = 63


def fit_name(prefix, core, suffix=""):
    name = prefix + core + suffix
    if len(name.encode("utf-8")) <= MAX_NAME_BYTES:
        return name
    tag = "~" + hashlib.sha1(core.encode("utf-8")).hexdigest()[:8]
    room = MAX_NAME_BYTES - len((prefix + tag + suffix).encode("utf-8"))
    if room < 1:
        raise ValueError("name parts too long to fit %d bytes: %r, %r" % (MAX_NAME_BYTES, prefix, suffix))
    short = core.encode("utf-8")[:room].decode("utf-8", "ignore")  # never half a character
    return prefix + short + tag + suffix
