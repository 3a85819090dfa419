# SPDX-License-Identifier: GPL-3.0-or-later
"""Contact sheets of the corpus benchmark, one JPEG per method (run by bench_corpus.py in Blender, which can
write JPEG):

  blender -b --factory-startup --python-exit-code 1 --python python_tests/bench/corpus_sheets.py -- SPEC.json

SPEC: {rows: [{sample, mesh, method, ok, sample_file, folder, seam, detail, patch, density}], docs, methods, row,
quality} (docs: the output folder; row: the cell size in px; quality: JPEG quality). One
row per run of the method, bunny first, in the order of the runs, under a label "[mesh:]sample s<seam>
d<detail> p<patch> c<complete> n<density>" (mesh named unless it is the bunny; "+ov": run again with --allow-oversized after the defaults refused it) in a 5 x 7 pixel font. Columns, each ROW px tall: the whole sample fitted in ROW x ROW; the
sample's centre at 1:1; the result at 1:1 (ROW x ROW from the front measurement view, flat_front.png: the
window with the most measured pixels nearest the centre); the CLI's Eevee render cropped to the object and
fitted in 4/3 ROW x ROW. A failed run shows a dark red result cell. A 4 px strip at the left of each row gives
the mesh (bunny white, part blue, elk green, anchor orange). <docs>/sheet_<method>.jpg and
<docs>/sheet_rows.json (row order per sheet: mesh and sample names).
"""
import json
import os
import sys

import bpy
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from sheet_text import draw_text  # noqa: E402

ROW = 96      # set from the spec's "row" in main()
GAP = 3
QUALITY = 80  # the spec's "quality"

LABEL = 10  # label strip height above each row


MESH_COLOURS = {"bunny": (1.0, 1.0, 1.0), "part": (0.3, 0.5, 1.0), "elk": (0.3, 0.8, 0.3), "anchor": (1.0, 0.6, 0.2)}


def load(path):
    """(H, W, 4) floats, row 0 = top."""
    image = bpy.data.images.load(path, check_existing=False)
    width, height = image.size
    pixels = np.empty(width * height * image.channels, np.float32)
    image.pixels.foreach_get(pixels)
    channels = image.channels
    bpy.data.images.remove(image)
    a = pixels.reshape(height, width, channels)[::-1]
    if channels == 1:
        a = np.repeat(a, 3, 2)
    if a.shape[2] == 3:
        a = np.concatenate([a, np.ones(a.shape[:2] + (1,), np.float32)], 2)
    return a.astype(np.float64)


def fit(a, width, height):
    """Box-filtered (area) resize to fit in width x height, centred on black."""
    h, w = a.shape[:2]
    scale = min(width / w, height / h)
    nw, nh = max(1, int(round(w * scale))), max(1, int(round(h * scale)))
    ys = np.minimum((np.arange(nh + 1) * h / nh).astype(int), h)
    xs = np.minimum((np.arange(nw + 1) * w / nw).astype(int), w)
    cs = np.cumsum(np.cumsum(np.pad(a[..., :3], ((1, 0), (1, 0), (0, 0))), 0), 1)
    y0, y1 = ys[:-1], np.maximum(ys[1:], ys[:-1] + 1)
    x0, x1 = xs[:-1], np.maximum(xs[1:], xs[:-1] + 1)
    total = (cs[y1][:, x1] - cs[y0][:, x1] - cs[y1][:, x0] + cs[y0][:, x0])
    area = ((y1 - y0)[:, None] * (x1 - x0)[None, :])[..., None]
    small = total / area
    out = np.zeros((height, width, 3))
    oy, ox = (height - nh) // 2, (width - nw) // 2
    out[oy:oy + nh, ox:ox + nw] = small
    return out


def centre_crop(a, size):
    h, w = a.shape[:2]
    if h < size or w < size:  # every sample smaller than a cell is tileable: repeat it, as tiling would
        a = np.pad(a, ((0, max(0, size - h)), (0, max(0, size - w)), (0, 0)), mode="wrap")
        h, w = a.shape[:2]
    out = np.zeros((size, size, 3))
    y0, x0 = max(0, (h - size) // 2), max(0, (w - size) // 2)
    part = a[y0:y0 + size, x0:x0 + size, :3]
    out[:part.shape[0], :part.shape[1]] = part
    return out


def best_window(flat, masks, size):
    """The size x size window of flat with the most measured (green) pixels, nearest the centre on ties."""
    valid = masks[..., 1] > 0.5
    h, w = valid.shape
    cs = np.pad(np.cumsum(np.cumsum(valid, 0), 1), ((1, 0), (1, 0)))
    counts = cs[size:, size:] - cs[:-size, size:] - cs[size:, :-size] + cs[:-size, :-size]
    yy, xx = np.mgrid[0:counts.shape[0], 0:counts.shape[1]]
    centre = -np.hypot(yy - (h - size) / 2, xx - (w - size) / 2) * 1e-3
    y, x = np.unravel_index(np.argmax(counts + centre), counts.shape)
    return flat[y:y + size, x:x + size, :3] * flat[y:y + size, x:x + size, 3:4]


def object_crop(render):
    """The render cropped to the pixels that differ from its corner (world) colour."""
    corner = render[0, 0, :3]
    differs = np.abs(render[..., :3] - corner).max(-1) > 0.02
    if not differs.any():
        return render
    ys, xs = np.nonzero(differs)
    pad = 6
    return render[max(0, ys.min() - pad):ys.max() + pad + 1, max(0, xs.min() - pad):xs.max() + pad + 1]


def figure(value):
    return "-" if value is None else "%.2f" % value if value < 9.995 else "%.0f" % value


def label_text(row):
    text = row["sample"] if row["mesh"] == "bunny" else "%s:%s" % (row["mesh"], row["sample"])
    if row.get("variant"):
        text += "+ov"
    if not row["ok"]:
        return text + "  failed"
    text += " s%s d%s p%s c%s" % (figure(row.get("seam")), figure(row.get("detail")), figure(row.get("patch")),
                                   figure(row.get("complete")))
    if row.get("density") is not None:
        text += " n%s" % figure(row["density"])
    return text


def sheet_width():
    return 4 + GAP + ROW + GAP + ROW + GAP + ROW + GAP + ROW * 4 // 3


def row_picture(row):
    width = sheet_width()
    out = np.full((ROW, width, 3), 0.12)
    out[:, :4] = MESH_COLOURS.get(row["mesh"], (0.5, 0.5, 0.5))
    x = 4 + GAP
    sample = load(row["sample_file"])
    out[:, x:x + ROW] = fit(sample, ROW, ROW)
    x += ROW + GAP
    out[:, x:x + ROW] = centre_crop(sample, ROW)
    x += ROW + GAP
    folder = row["folder"]
    flat = os.path.join(folder, "flat_front.png")
    masks = os.path.join(folder, "masks_front.png")
    if row["ok"] and os.path.isfile(flat) and os.path.isfile(masks):
        out[:, x:x + ROW] = best_window(load(flat), load(masks), ROW)
    else:
        out[:, x:x + ROW] = (0.35, 0.05, 0.05)
    x += ROW + GAP
    render = os.path.join(folder, "render.png")
    if os.path.isfile(render):
        out[:, x:x + ROW * 4 // 3] = fit(object_crop(load(render)), ROW * 4 // 3, ROW)
    else:
        out[:, x:x + ROW * 4 // 3] = (0.35, 0.05, 0.05)
    return out


def save_jpeg(path, rgb):
    h, w = rgb.shape[:2]
    rgba = np.ones((h, w, 4), np.float32)
    rgba[..., :3] = np.clip(rgb, 0, 1)
    image = bpy.data.images.new("sheet", w, h)
    image.pixels.foreach_set(rgba[::-1].ravel())
    scene = bpy.context.scene
    scene.render.image_settings.file_format = "JPEG"
    scene.render.image_settings.quality = QUALITY
    scene.render.image_settings.color_mode = "RGB"
    image.save_render(path, scene=scene)
    bpy.data.images.remove(image)


def main():
    spec_path = sys.argv[sys.argv.index("--") + 1]
    with open(spec_path) as handle:
        spec = json.load(handle)
    global ROW, QUALITY
    ROW, QUALITY = int(spec.get("row", ROW)), int(spec.get("quality", QUALITY))
    os.makedirs(spec["docs"], exist_ok=True)
    bpy.context.scene.view_settings.view_transform = "Standard"
    order = {}
    for method in spec["methods"]:
        rows = [r for r in spec["rows"] if r["method"] == method]
        rows.sort(key=lambda r: r["mesh"] != "bunny")
        if not rows:
            continue
        pictures = [row_picture(r) for r in rows]
        step = LABEL + ROW + GAP
        sheet = np.full((LABEL + len(pictures) * step, sheet_width(), 3), 0.0)
        draw_text(sheet, "%s: sample  sample 1:1  result 1:1  render" % method, 1, 2, (1.0, 0.85, 0.3))
        for i, (picture, row) in enumerate(zip(pictures, rows)):
            top = LABEL + i * step
            draw_text(sheet, label_text(row), top + 1, 2)
            sheet[top + LABEL:top + LABEL + ROW] = picture
        path = os.path.join(spec["docs"], "sheet_%s.jpg" % method)
        save_jpeg(path, sheet)
        order[method] = ["%s/%s" % (r["mesh"], r["sample"]) for r in rows]
        print("corpus_sheets: %s (%d rows, %d KB)" % (path, len(rows), os.path.getsize(path) // 1024))
    with open(os.path.join(spec["docs"], "sheet_rows.json"), "w") as handle:
        json.dump(order, handle, indent=1)


main()
