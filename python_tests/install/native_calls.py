# SPDX-License-Identifier: GPL-3.0-or-later
"""The native entry points of every TexSynth method on one small mesh, saved for a bit-for-bit comparison
between two builds of texsynth_native (issue 31's foreign runtime: a self-contained package's module against
the Debian-built one).

Standalone: needs python3, numpy and texsynth_native (found on sys.path / PYTHONPATH) and nothing else
(no pytest, bpy, add-on or test helpers, no image files: every input is built here with numpy, and the only
files read are the module's own cache files, written to a temporary directory that is removed afterwards).

    python3 native_calls.py run OUT.npz [--cpus N]
        Builds a deterministic mesh, sample image and direction field, calls jump map, texton strings, round
        neighbourhoods, vector-field patches, texture particles, Embree ray casts / orientation fields and the
        histogram transform (through its EXR cache), and saves every output array in OUT.npz under
        "<call>.<output>" (structured arrays one key per field, timings left out) plus "version".
        Prints one line per call: its outputs' shapes and a short hash of them.
        --cpus N: restrict the process to N of its CPUs before the module is imported (TBB sizes its thread
        pool from the CPU affinity), to show that the outputs do not depend on the thread count.

    python3 native_calls.py compare A.npz B.npz [--exact KEY_PREFIX ...]
        Per key: "equal" (bit for bit) or the largest absolute difference and the number of differing values.
        Exit status 1 when a key is missing from either file, has another shape or dtype, or differs at all
        while it is in the exact set (keys starting with one of the KEY_PREFIXes; default: every key). Ends
        with "native_calls: N keys, E equal, D differ". Needs only numpy.
"""
import argparse
import hashlib
import os
import shutil
import sys
import tempfile
import time

import numpy as np

GRID = 16  # cells per side: 289 vertices, 512 triangles
SAMPLE = 48  # sample side in pixels
TARGET = 64  # baked image side in texels (round neighbourhoods, patches)


# ---------------------------------------------------------------- inputs

def make_mesh(seed=11):
    """A gently curved, subdivided unit grid: interior vertices jittered in x/y (seeded), the border
    straight. The UV map is x, y shrunk into [0.06, 0.94] (texels around it are bake margin). Counter-clockwise
    triangles seen from +z.
    Returns positions (V, 3) float32, triangles (T, 3) int32, corner UVs (T, 3, 2) float32."""
    rng = np.random.default_rng(seed)
    ys, xs = np.mgrid[0:GRID + 1, 0:GRID + 1]
    xy = np.stack([xs.ravel(), ys.ravel()], 1).astype(np.float64) / GRID
    interior = (xs.ravel() > 0) & (xs.ravel() < GRID) & (ys.ravel() > 0) & (ys.ravel() < GRID)
    xy[interior] += (rng.random((int(interior.sum()), 2)) - 0.5) * (0.3 / GRID)
    z = 0.12 * np.sin(np.pi * xy[:, 0]) * np.cos(0.6 * np.pi * (xy[:, 1] - 0.5)) + 0.05 * xy[:, 1] ** 2
    positions = np.column_stack([xy, z]).astype(np.float32)
    index = lambda x, y: y * (GRID + 1) + x
    triangles = []
    for y in range(GRID):
        for x in range(GRID):
            a, b, c, d = index(x, y), index(x + 1, y), index(x + 1, y + 1), index(x, y + 1)
            # Alternate the diagonal so the mesh is not a uniform fan.
            triangles += [[a, b, c], [a, c, d]] if (x + y) % 2 == 0 else [[a, b, d], [b, c, d]]
    triangles = np.array(triangles, np.int32)
    corner_uvs = np.ascontiguousarray(0.06 + 0.88 * xy[triangles], np.float32)
    return positions, triangles, corner_uvs


def blender_layout(triangles):
    """The triangles as Blender polygons: corner_verts (L,), poly_starts (F,), poly_sizes (F,)."""
    count = triangles.shape[0]
    return (np.ascontiguousarray(triangles.ravel(), np.int32), np.arange(count, dtype=np.int32) * 3,
            np.full(count, 3, np.int32))


def make_sample(seed=5):
    """48 x 48 RGB uint8 with structure: a smooth seeded background (bilinearly enlarged noise), discs of
    two colour families on it (texture particles), and a little fine noise."""
    rng = np.random.default_rng(seed)
    coarse = rng.random((7, 7, 3))
    t = np.linspace(0.0, 6.0, SAMPLE)
    i0 = np.minimum(np.floor(t).astype(int), 5)
    f = (t - i0)[:, None]
    rows = coarse[i0] * (1 - f[:, :, None]) + coarse[i0 + 1] * f[:, :, None]  # (48, 7, 3)
    image = rows[:, i0] * (1 - f[None, :, :]) + rows[:, i0 + 1] * f[None, :, :]  # (48, 48, 3)
    image = 0.25 + 0.3 * image
    ys, xs = np.mgrid[0:SAMPLE, 0:SAMPLE] + 0.5
    families = np.array([[0.85, 0.55, 0.2], [0.2, 0.35, 0.8]])
    for k in range(14):
        cx, cy = rng.random(2) * SAMPLE
        radius = 2.5 + 2.5 * rng.random()
        colour = families[k % 2] + 0.06 * (rng.random(3) - 0.5)
        inside = (xs - cx) ** 2 + (ys - cy) ** 2 <= radius ** 2
        image[inside] = colour
    image += 0.04 * (rng.random(image.shape) - 0.5)
    return np.ascontiguousarray(np.clip(np.round(image * 255.0), 0, 255).astype(np.uint8))


def make_directions(positions):
    """The texture's 'up' per vertex: +y turned gently around the grid's centre (not unit, not tangent:
    every method projects and normalises)."""
    p = positions.astype(np.float64)
    up = np.column_stack([-0.6 * (p[:, 1] - 0.5), np.ones(len(p)), 0.2 * (p[:, 0] - 0.5)])
    return np.ascontiguousarray(up, np.float32)


# ---------------------------------------------------------------- outputs

def flatten(out, prefix, value):
    """Adds value under prefix: dicts and lists recursively ('prefix.key', 'prefix.i'), structured arrays one
    key per field, strings and scalars as 0-d arrays. Timings ('seconds*') and None are left out."""
    if value is None:
        return
    if isinstance(value, dict):
        for key in sorted(value):
            if not str(key).startswith("seconds"):
                flatten(out, "%s.%s" % (prefix, key), value[key])
        return
    if isinstance(value, (list, tuple)):
        array = np.asarray(value) if value and all(isinstance(v, (bool, int, float, np.number)) for v in value) \
            else None
        if array is None:
            for i, item in enumerate(value):
                flatten(out, "%s.%d" % (prefix, i), item)
        else:
            out[prefix] = array
        return
    if isinstance(value, np.ndarray) and value.dtype.names:
        for name in value.dtype.names:
            out["%s.%s" % (prefix, name)] = np.ascontiguousarray(value[name])
        return
    array = np.asarray(value)
    if array.dtype == object:
        raise TypeError("%s: cannot save a %s" % (prefix, type(value).__name__))
    out[prefix] = array


def digest(arrays):
    h = hashlib.sha256()
    for array in arrays:
        array = np.ascontiguousarray(array)
        h.update(("%s%s" % (array.dtype.str, array.shape)).encode())
        h.update(array.tobytes())
    return h.hexdigest()[:12]


class Recorder:
    def __init__(self):
        self.arrays = {}

    def call(self, name, function):
        """Runs function() -> {output: value}, stores the outputs under 'name.output' and prints one line."""
        start = time.perf_counter()
        outputs = function()
        seconds = time.perf_counter() - start
        added = {}
        for key, value in outputs.items():
            flatten(added, "%s.%s" % (name, key), value)
        clash = set(added) & set(self.arrays)
        assert not clash, clash
        self.arrays.update(added)
        shapes = " ".join("%s%s" % (key[len(name) + 1:], "(%s)" % ",".join(map(str, a.shape)))
                          for key, a in added.items() if a.ndim > 0 and a.size > 1)
        print("%-22s %6.3f s  %3d keys  sha256 %s  %s" % (name, seconds, len(added),
                                                           digest(added[k] for k in sorted(added)), shapes),
              flush=True)
        return outputs


# ---------------------------------------------------------------- run

def run(out_path, cpus=None):
    if cpus:
        allowed = sorted(os.sched_getaffinity(0))
        os.sched_setaffinity(0, allowed[:cpus])  # before the module (and TBB) starts any thread
    import texsynth_native as tn

    total = time.perf_counter()
    print("texsynth_native %s from %s, %d CPUs allowed" % (tn.__version__, tn.__file__, len(os.sched_getaffinity(0))),
          flush=True)
    positions, triangles, corner_uvs = make_mesh()
    mesh = (positions,) + blender_layout(triangles)  # positions, corner_verts, poly_starts, poly_sizes
    sample_u8 = make_sample()
    sample = np.ascontiguousarray(sample_u8.astype(np.float32) / 255.0)  # the float image the methods take
    directions = make_directions(positions)
    rec = Recorder()
    rec.arrays["version"] = np.asarray(tn.__version__)
    rec.call("inputs", lambda: {"positions": positions, "triangles": triangles, "sample": sample_u8,
                                "directions": directions})
    cache_dir = tempfile.mkdtemp(prefix="texsynth-native-calls-")
    try:
        # 1. Jump map (Zelinka & Garland): preprocess, then the jump-map walk.
        holder = {}

        def preprocess():
            pre = tn.preprocess(sample, jump_candidates=4, seed=1)
            holder["pre"] = pre
            return {name: getattr(pre, name) for name in (
                "jump_targets", "jump_weights", "texton_map", "texton_distances", "textons", "bucket_pixels",
                "bucket_start", "num_textons", "sample_hash")}

        rec.call("preprocess", preprocess)
        pre = holder["pre"]

        def preprocess_cached():
            # The module's own cache file: written by the first call, loaded (not recomputed) by the second.
            first = tn.preprocess(sample, jump_candidates=4, seed=1, cache_dir=cache_dir)
            second = tn.preprocess(sample, jump_candidates=4, seed=1, cache_dir=cache_dir)
            assert not first.cache_hit and second.cache_hit, (first.cache_status, second.cache_status)
            return {"cache_hit": second.cache_hit, "jump_targets": second.jump_targets,
                    "jump_weights": second.jump_weights, "texton_map": second.texton_map, "textons": second.textons}

        rec.call("preprocess_cached", preprocess_cached)
        jump = rec.call("jumpmap", lambda: tn.synthesize_jumpmap(pre, *mesh, scale=60.0, seed=4, orientation="field",
                                                                 direction=directions))

        # 2. Texton strings (Magda & Kriegman) and the continuity error of any mapping.
        rec.call("texton", lambda: tn.synthesize_texton(pre, sample, *mesh, scale=40.0, seed=5, orientation="field",
                                                         direction=directions, seeds_per_component=2))

        def continuity():
            edges, error = tn.edge_continuity_error(sample, *mesh, jump["base_uv"])
            return {"edge_vertices": edges, "edge_error": error}

        rec.call("edge_continuity", continuity)

        # 3. Round neighbourhoods (Chen & Dong): an image target and a vertex target.
        def round_image():
            context = tn.RoundSynthesisContext(positions, triangles, corner_uvs, width=TARGET, height=TARGET,
                                               texels_per_unit=40.0)
            out = tn.round_synthesize(context, sample, directions, seed=3)
            out["num_points"] = context.num_points
            return out

        rec.call("round", round_image)

        def round_vertices():
            context = tn.RoundSynthesisContext(positions, triangles, target="vertices", texels_per_unit=40.0)
            return tn.round_synthesize(context, sample, directions, seed=6, random_candidates=3)

        rec.call("round_vertices", round_vertices)

        # 4. Vector-field patches: exemplar, field, texel samples, synthesis (sampling and optimisation).
        texels = rec.call("texels", lambda: tn.sample_texels(positions, triangles, corner_uvs, TARGET, TARGET))
        patch_inputs = {}

        def exemplar():
            ex = tn.patch_exemplar(sample, patch_size=16, seed=1)
            patch_inputs["exemplar"] = ex
            return {"key": ex.key, "patch_size": ex.patch_size}

        rec.call("patch_exemplar", exemplar)

        def field():
            f = tn.patch_field(positions, triangles, directions, spacing=1.0 / 40.0)
            patch_inputs["field"] = f
            return {"scale": f.scale, "unset_vertices": f.unset_vertices}

        rec.call("patch_field", field)
        samples = (texels["position"], texels["normal"], texels["triangle"], texels["barycentric"])
        rec.call("patches", lambda: tn.synthesize_patches(patch_inputs["field"], patch_inputs["exemplar"], sample,
                                                          *samples, seed=2, boundary_width=2))
        rec.call("patches_optimisation", lambda: tn.synthesize_patches(
            patch_inputs["field"], patch_inputs["exemplar"], sample, *samples, mode="optimisation", seed=2,
            levels=2, boundary_width=2, iterations=2, candidates=8))

        # 5. Texture particles: analysis, placement, sprites and decal polygons.
        particle_inputs = {}

        def analysis():
            a = tn.particle_analysis(sample, classes=3, seed=1)
            particle_inputs["analysis"] = a
            return {"labels": a.labels, "components": a.components, "background": a.background,
                    "particles": a.particles, "classes": a.classes, "class_pairs": a.class_pairs,
                    "cooccurrences": a.cooccurrences, "background_class": a.background_class,
                    "min_area": a.min_area, "merged_components": a.merged_components}

        rec.call("particle_analysis", analysis)
        walk_mesh = tn.surface_walk_mesh(positions, triangles)
        placed = rec.call("particles", lambda: tn.place_particles(particle_inputs["analysis"], walk_mesh, directions,
                                                                 sample_world_width=0.6, seed=3))

        def decals():
            a = particle_inputs["analysis"]
            sprites = np.asarray(placed["sprite"], np.int64)
            boxes, rgba = {}, []
            for sprite in np.unique(sprites):
                s = tn.particle_sprite(a, sample, int(sprite))
                h, w = s["rgba"].shape[:2]
                boxes[int(sprite)] = (float(s["origin"][0]), float(s["origin"][1]), float(w), float(h))
                rgba.append(s["rgba"].ravel())
            centres = np.asarray(a.particles["box_centre"], np.float64)[sprites].reshape(-1, 2)
            box = np.array([boxes[int(s)] for s in sprites], np.float64).reshape(-1, 4)
            size = np.asarray(placed["pixel_size"], np.float64)[:, None]
            rects = np.column_stack([box[:, 0] - centres[:, 0], box[:, 1] - centres[:, 1],
                                     box[:, 0] + box[:, 2] - centres[:, 0], box[:, 1] + box[:, 3] - centres[:, 1]])
            rects = np.ascontiguousarray(rects * size, np.float32)
            uv_rects = np.tile(np.array([0.0, 0.0, 1.0, 1.0], np.float32), (len(sprites), 1))
            out = tn.decal_mesh(walk_mesh, placed["triangle"], placed["barycentric"], placed["sprite_axis"], rects,
                                uv_rects, offset=0.002)
            out["sprite_rgba"] = np.concatenate(rgba) if rgba else np.zeros(0, np.float32)
            return out

        rec.call("decals", decals)

        # 6. Embree (RayCaster) and orientation fields.
        def raycast():
            caster = tn.RayCaster(*mesh)
            rng = np.random.default_rng(17)
            n = 96
            origins = np.column_stack([rng.random(n) * 1.2 - 0.1, rng.random(n) * 1.2 - 0.1, np.full(n, 1.0)])
            rays = np.column_stack([0.15 * (rng.random(n) - 0.5), 0.15 * (rng.random(n) - 0.5), -np.ones(n)])
            origins[::4, 2] = -1.0  # every fourth ray from below, upwards (back faces)
            rays[::4, 2] = 1.0
            hits = caster.cast(origins.astype(np.float32), rays.astype(np.float32))
            ids, distances = caster.vertices_within(positions[GRID * (GRID + 1) // 2 + 3], 0.2)
            hits.update(within_ids=ids, within_distances=distances, num_triangles=caster.num_triangles)
            return hits

        rec.call("raycast", raycast)
        rec.call("field", lambda: {
            "axis": tn.compute_field(*mesh, orientation="axis", axis=(0.3, 1.0, 0.2)),
            "anchors": tn.compute_field(*mesh, orientation="anchors", anchor_vertices=np.array([20, 200], np.int32),
                                        anchor_directions=np.array([[1.0, 0.2, 0.0], [0.0, 1.0, 0.1]], np.float32)),
            "field": tn.compute_field(*mesh, orientation="field", direction=directions)})

        # 7. Histogram transform: the cache's Gaussianized sample and look-up table, written as OpenEXR
        # (tinyexr in the self-contained module) and read back by the second call.
        def histogram():
            computed = tn.histogram_transform(sample_u8, cache_dir=cache_dir, lut_size=256)
            paths = (computed["gaussian_path"], computed["lut_path"])
            stamps = [os.stat(p).st_mtime_ns for p in paths]
            cached = tn.histogram_transform(sample_u8, cache_dir=cache_dir, lut_size=256)
            reused = [os.stat(p).st_mtime_ns for p in paths] == stamps and \
                (cached["gaussian_path"], cached["lut_path"]) == paths
            assert reused, "the second histogram_transform rewrote its cache files"
            keep = ("gaussian", "inverse_lut", "ok", "fallback_reason", "colour_channels")
            return {"computed": {k: computed[k] for k in keep}, "cached": {k: cached[k] for k in keep},
                    "files_reused": reused}

        rec.call("histogram", histogram)
    finally:
        shutil.rmtree(cache_dir, ignore_errors=True)

    with open(out_path, "wb") as handle:  # the path as given (np.savez would append .npz to a bare name)
        np.savez(handle, **rec.arrays)
    print("saved %d keys to %s in %.2f s (process threads at the end: %d)" % (
        len(rec.arrays), out_path, time.perf_counter() - total, len(os.listdir("/proc/self/task"))), flush=True)


# ---------------------------------------------------------------- compare

def differing(a, b):
    """Boolean array (a's shape) of the values whose bits differ."""
    if a.dtype.kind == "U":
        return a != b
    width = a.dtype.itemsize
    ra = np.ascontiguousarray(a).view(np.uint8).reshape(a.shape + (width,)) if a.ndim else \
        np.frombuffer(a.tobytes(), np.uint8)
    rb = np.ascontiguousarray(b).view(np.uint8).reshape(b.shape + (width,)) if b.ndim else \
        np.frombuffer(b.tobytes(), np.uint8)
    return np.any(ra != rb, axis=-1)


def max_abs_difference(a, b, mask):
    if a.dtype.kind not in "biuf" or not mask.any():
        return None
    x, y = a[mask].astype(np.float64), b[mask].astype(np.float64)
    finite = np.isfinite(x) & np.isfinite(y)
    if not finite.any():
        return float("nan")
    return float(np.max(np.abs(x[finite] - y[finite])))


def compare(path_a, path_b, exact_prefixes=None, tolerances=None):
    """Exit status 0 when every key is equal bit for bit, except keys under a `tolerances` prefix (floats
    within that absolute difference) or, when `exact_prefixes` is given, keys outside it (reported only)."""
    tolerances = tolerances or {}
    with np.load(path_a, allow_pickle=False) as fa, np.load(path_b, allow_pickle=False) as fb:
        a = {k: fa[k] for k in fa.files}
        b = {k: fb[k] for k in fb.files}
    tolerance_of = lambda key: next((t for p, t in tolerances.items() if key.startswith(p)), None)
    exact = lambda key: tolerance_of(key) is None and (
        exact_prefixes is None or any(key.startswith(p) for p in exact_prefixes))
    keys = sorted(set(a) | set(b))
    equal = differ = 0
    failed = []
    for key in keys:
        if key not in a or key not in b:
            print("%-48s missing in %s" % (key, path_a if key not in a else path_b))
            differ += 1
            failed.append(key)
            continue
        x, y = a[key], b[key]
        if x.shape != y.shape or x.dtype != y.dtype:
            print("%-48s shape/dtype %s %s against %s %s" % (key, x.shape, x.dtype, y.shape, y.dtype))
            differ += 1
            failed.append(key)
            continue
        mask = differing(x, y)
        count = int(np.count_nonzero(mask))
        if count == 0:
            print("%-48s equal" % key)
            equal += 1
            continue
        differ += 1
        diff = max_abs_difference(x, y, mask)
        tolerance = tolerance_of(key)
        within = tolerance is not None and diff is not None and diff <= tolerance
        note = "" if exact(key) else " (within %g)" % tolerance if within else \
            " (ABOVE %g)" % tolerance if tolerance is not None else " (tolerated)"
        print("%-48s max abs difference %s, %d of %d values differ%s" % (
            key, "n/a" if diff is None else "%.6g" % diff, count, x.size, note))
        if exact(key) or (tolerance is not None and not within):
            failed.append(key)
    print("native_calls: %d keys, %d equal, %d differ" % (len(keys), equal, differ))
    return 1 if failed else 0


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    commands = parser.add_subparsers(dest="command", required=True)
    run_parser = commands.add_parser("run", help="call every method and save the outputs")
    run_parser.add_argument("out", help="the .npz to write")
    run_parser.add_argument("--cpus", type=int, default=None, help="restrict the process to this many CPUs first")
    compare_parser = commands.add_parser("compare", help="compare two saved runs")
    compare_parser.add_argument("a")
    compare_parser.add_argument("b")
    compare_parser.add_argument("--exact", nargs="+", metavar="KEY_PREFIX", default=None,
                                help="keys that must be equal bit for bit (default: all)")
    compare_parser.add_argument("--tolerance", action="append", default=[], metavar="KEY_PREFIX=ABS",
                                help="keys that may differ by at most ABS (repeatable); all others stay exact")
    args = parser.parse_args(argv)
    if args.command == "run":
        if args.cpus is not None and args.cpus < 1:
            parser.error("--cpus must be at least 1")
        run(args.out, args.cpus)
        return 0
    tolerances = {}
    for item in args.tolerance:
        prefix, _, value = item.partition("=")
        try:
            tolerances[prefix] = float(value)
        except ValueError:
            parser.error("--tolerance takes KEY_PREFIX=ABS, got %r" % item)
    return compare(args.a, args.b, args.exact, tolerances)


if __name__ == "__main__":
    sys.exit(main())
