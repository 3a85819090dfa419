# SPDX-License-Identifier: GPL-3.0-or-later
"""Reference frames: renders blend_samples/scene.blend textured by TexSynth (Eevee and Cycles, fixed
seeds and samples) and compares each to python_tests/references/blender<major>/<name>.png with idiff.

Eevee changed between major versions (Eevee Next in 4.2), so each major version has its own references,
all held to the same thresholds.

On failure the render and idiff's difference image are left in out/reference_frames/blender<major>/
(<name>.png, <name>_diff.png). TEXSYNTH_UPDATE_REFERENCES=1 rewrites the references instead.
"""
import os
import shutil
import subprocess

import pytest

import addon_package
import blender_run



def references_dir():
    return os.path.join(addon_package.ROOT, "python_tests", "references",
                        "blender%d" % addon_package.blender_version()[0])


def output_dir():
    return os.path.join(addon_package.ROOT, "out", "reference_frames", "blender%d" % addon_package.blender_version()[0])


FRAMES = ("scene_eevee", "suzanne_noblend_eevee", "scene_cycles", "suzanne_round_eevee")
# A pixel fails when a channel differs by more than 0.06 (~15/255); a frame fails when more than 0.5 %
# of its pixels fail or any pixel differs by more than 0.6. Software-GL Eevee is deterministic here;
# the margins absorb driver and CPU differences, not changes of the synthesized mapping.
IDIFF_THRESHOLDS = ["-fail", "0.06", "-failpercent", "0.5", "-hardfail", "0.6", "-warn", "0.02",
                    "-warnpercent", "0.5"]


@pytest.mark.skipif(not addon_package.real_synthesizer_available(),
                    reason="texsynth_native lacks synthesize_jumpmap: reference frames need the real synthesizer")
@pytest.mark.parametrize("name", FRAMES)
def test_reference_frame(name, tmp_path):
    output = output_dir()
    os.makedirs(output, exist_ok=True)
    rendered = os.path.join(output, name + ".png")
    if os.path.exists(rendered):
        os.remove(rendered)
    process = blender_run.blender("--python", os.path.join(blender_run.BLENDER_TESTS, "render_frame.py"), "--",
                                  name, rendered, blend_file=os.path.join(blender_run.SAMPLES, "scene.blend"),
                                  env={"TEXSYNTH_CACHE_DIR": str(tmp_path / "cache")})
    assert process.returncode == 0 and os.path.isfile(rendered), process.stdout[-3000:] + process.stderr[-3000:]
    reference = os.path.join(references_dir(), name + ".png")
    if os.environ.get("TEXSYNTH_UPDATE_REFERENCES") == "1":
        os.makedirs(references_dir(), exist_ok=True)
        shutil.copyfile(rendered, reference)
        return
    assert os.path.isfile(reference), "no reference %s: run with TEXSYNTH_UPDATE_REFERENCES=1" % reference
    diff = os.path.join(output, name + "_diff.png")
    compare = subprocess.run(["idiff"] + IDIFF_THRESHOLDS + ["-od", "-o", diff, reference, rendered],
                             capture_output=True, text=True)
    # idiff: 0 = match, 1 = within warning limits, 2+ = failure or error.
    assert compare.returncode in (0, 1), "frame %s differs from its reference (diff image: %s)\n%s" % (
        name, diff, compare.stdout[-2000:])
    if os.path.exists(diff) and compare.returncode == 0:
        os.remove(diff)
