# SPDX-License-Identifier: GPL-3.0-or-later
"""Runs hostile cases against texsynth_native, one JSON line per case on stdout.

    python3 worker.py CORPUS_DIR CASES.json FIRST_INDEX

Prints {"start": i} before case i and {"index": i, "outcome": ..., ...} after it, so the parent
(run_hostile.py) can tell which case a crash or hang happened in and restart after it.
Outcomes: "ok" (valid result), "error" (clear error: ValueError/CacheError/TypeError with a message),
"invalid" (result breaks the contract), "unclear" (other exception type or empty message),
"partial" (failed but left a file behind or changed its inputs).
"""
import hashlib
import json
import os
import resource
import shutil
import sys
import tempfile
import time

import numpy as np

import make_corpus

CLEAR_ERRORS = (ValueError, TypeError)  # CacheError is a ValueError


def digest(*arrays):
    h = hashlib.sha256()
    for a in arrays:
        if isinstance(a, np.ndarray):
            h.update(str((a.dtype, a.shape)).encode())
            h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


def listing(folder):
    return sorted(os.listdir(folder)) if os.path.isdir(folder) else []


class Invalid(Exception):
    """The call returned, but its result breaks the contract."""


def check_preprocessed(native, pre, width=None, height=None):
    if width is not None and (pre.width, pre.height) != (width, height):
        raise Invalid("size %dx%d, expected %dx%d" % (pre.width, pre.height, width, height))
    tmap = pre.texton_map
    if tmap.shape != (pre.height, pre.width) or tmap.min() < 0 or tmap.max() >= pre.num_textons:
        raise Invalid("texton map out of range")
    targets = pre.jump_targets
    if targets.min() < -1 or targets.max() >= pre.width * pre.height:
        raise Invalid("jump target out of range")
    if not np.all(np.isfinite(pre.textons)):
        raise Invalid("non-finite textons")


def check_synth(result, corner_count):
    base, blend, weights = result["base_uv"], result["blend_uv"], result["blend_weights"]
    s = result["num_blend_sets"]
    if base.shape != (corner_count, 2) or blend.shape != (s, corner_count, 2) or weights.shape != (corner_count, s):
        raise Invalid("output shapes %s %s %s for %d corners" % (base.shape, blend.shape, weights.shape, corner_count))
    for name, a in (("base_uv", base), ("blend_uv", blend), ("blend_weights", weights)):
        if not np.all(np.isfinite(a)):
            raise Invalid("non-finite values in " + name)
    if weights.size and (weights.min() < 0 or weights.max() > 1):
        raise Invalid("weights outside [0, 1]")


class Runner:
    def __init__(self, native, corpus):
        self.native, self.corpus = native, corpus
        self.cache_dir = tempfile.mkdtemp(prefix="texsynth_hostile_cache_")
        self._pre = None

    def path(self, relative):
        return os.path.join(self.corpus, relative)

    def sample(self):
        if self._pre is None:
            self._pre = self.native.preprocess(self.path("images/sample.png"), **make_corpus.SMALL_PARAMS)
        return self._pre

    def preprocess_checked(self, image, params, width=None, height=None):
        """preprocess with a fresh cache dir: a failure must leave the dir empty, a success a loadable cache."""
        folder = tempfile.mkdtemp(dir=self.cache_dir)
        try:
            pre = self.native.preprocess(image, cache_dir=folder, **params)
        except BaseException:
            if listing(folder):
                raise PartialWrite("failed preprocess left %s in the cache dir" % listing(folder))
            raise
        files = listing(folder)
        if len(files) != 1:
            raise PartialWrite("cache dir holds %s after a successful preprocess" % files)
        check_preprocessed(self.native, self.native.load_preprocessed(os.path.join(folder, files[0])), width, height)
        check_preprocessed(self.native, pre, width, height)
        return pre

    def run(self, case):
        kind = case["kind"]
        if kind == "image":
            image = self.native.load_image(self.path(case["file"]))
            if image.ndim != 3 or not np.all(np.isfinite(image)):
                raise Invalid("load_image returned %s / non-finite" % (image.shape,))
            if image.shape[2] <= 4:
                try:
                    self.preprocess_checked(self.path(case["file"]), make_corpus.SMALL_PARAMS,
                                            image.shape[1], image.shape[0])
                except ValueError as error:
                    if "smaller than" not in str(error) and "channels" not in str(error):
                        raise
            return "decoded %s" % (image.shape,)
        if kind == "array":
            array = make_array(case["fill"], case["shape"], case["dtype"])
            before = digest(array)
            try:
                pre = self.preprocess_checked(array, make_corpus.SMALL_PARAMS)
            finally:
                if digest(array) != before:
                    raise PartialWrite("the input array was modified")
            return "%dx%d" % (pre.width, pre.height)
        if kind == "preprocess":
            pre = self.preprocess_checked(self.path(case["file"]), case["params"])
            return "K=%d" % pre.num_textons
        if kind == "cache":
            pre = self.native.load_preprocessed(self.path(case["file"]), expected_hash=case.get("expected_hash"))
            check_preprocessed(self.native, pre)
            return "loaded"
        if kind == "cache_dir":
            return self.cache_dir_case(case)
        if kind in ("mesh", "synth", "texton"):
            arrays = dict(np.load(self.path(case["mesh"])))
            return self.synthesize(arrays, dict(case["params"]), texton=kind == "texton")
        if kind == "huge_mesh":
            return self.huge(case)
        if os.environ.get("TEXSYNTH_HOSTILE_SELF_TEST") == "1":  # proves the parent detects these
            if kind == "crash_test":
                os.kill(os.getpid(), 11)
            if kind == "hang_test":
                time.sleep(3600)
        raise RuntimeError("unknown case kind " + kind)

    def cache_dir_case(self, case):
        image, params = self.path(case["image"]), case["params"]
        folder = tempfile.mkdtemp(dir=self.cache_dir)
        target = self.native.cache_file_path(image, cache_dir=folder, **params)
        shutil.copyfile(self.path(case["file"]), target)
        pre = self.native.preprocess(image, cache_dir=folder, **params)
        if pre.cache_status != "recomputed-corrupt":
            raise Invalid("corrupt cache was used (status %s)" % pre.cache_status)
        check_preprocessed(self.native, self.native.load_preprocessed(target))
        if listing(folder) != [os.path.basename(target)]:
            raise PartialWrite("stray files %s" % listing(folder))
        return pre.cache_status

    def sample_pixels(self):
        return self.native.load_image(self.path("images/sample.png"))

    def synthesize(self, arrays, params, texton=False):
        nv = arrays["positions"].shape[0] if arrays["positions"].ndim == 2 else 0
        for key in ("direction", "scale_multiplier", "normals"):
            if isinstance(params.get(key), str):
                params[key] = special_array(params[key], nv, key == "scale_multiplier")
        inputs = [arrays[k] for k in ("positions", "corner_verts", "poly_starts", "poly_sizes")]
        before = digest(*inputs, *[v for v in params.values() if isinstance(v, np.ndarray)])
        try:
            info = self.native.mesh_info(*inputs)
            if texton:
                result = self.native.synthesize_texton(self.sample(), self.sample_pixels(), *inputs, **params)
            else:
                result = self.native.synthesize_jumpmap(self.sample(), *inputs, **params)
        finally:
            if digest(*inputs, *[v for v in params.values() if isinstance(v, np.ndarray)]) != before:
                raise PartialWrite("input arrays were modified")
        check_synth(result, info["corners"])
        return "%d faces, %d jumps" % (info["faces"], result["stats"].get("jumps", -1))

    def huge(self, case):
        faces = case["faces"]
        side = int(np.sqrt(faces / 2))
        start = time.perf_counter()
        positions, corner_verts, poly_starts, poly_sizes = huge_triangle_grid(side)
        built = time.perf_counter() - start
        start = time.perf_counter()
        result = self.native.synthesize_jumpmap(self.sample(), positions, corner_verts, poly_starts, poly_sizes,
                                                **case["params"])
        seconds = time.perf_counter() - start
        check_synth(result, len(corner_verts))
        rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        return "%d faces, %d vertices: synthesis %.1f s (mesh arrays built in %.1f s), peak RSS %.0f MB" % (
            len(poly_sizes), len(positions), seconds, built, rss)


class PartialWrite(Exception):
    pass


def huge_triangle_grid(side):
    """side x side quads split in two triangles, built with numpy (no Python loops)."""
    xs, ys = np.meshgrid(np.arange(side + 1, dtype=np.float32), np.arange(side + 1, dtype=np.float32))
    positions = np.stack([xs.ravel(), ys.ravel(), np.zeros(xs.size, np.float32)], 1)
    qx, qy = np.meshgrid(np.arange(side, dtype=np.int32), np.arange(side, dtype=np.int32))
    v00 = (qy * (side + 1) + qx).ravel()
    v10, v01 = v00 + 1, v00 + side + 1
    v11 = v01 + 1
    corner_verts = np.stack([v00, v10, v11, v00, v11, v01], 1).ravel().astype(np.int32)
    faces = 2 * side * side
    return positions, corner_verts, np.arange(faces, dtype=np.int32) * 3, np.full(faces, 3, np.int32)


def make_array(fill, shape, dtype):
    if fill == "broadcast":
        return np.broadcast_to(np.zeros(1, dtype=dtype), shape)
    size = int(np.prod(shape))
    base = (np.arange(size) % 251 / 251.0).reshape(shape)
    if fill == "zeros":
        base = np.zeros(shape)
    elif fill in ("nan", "inf"):
        base = base.copy()
        base.flat[size // 2] = np.nan if fill == "nan" else np.inf
    elif fill == "strided":
        return np.asarray(np.concatenate([base, base], axis=1)[:, ::2], dtype=np.float32)
    if dtype == "uint16":
        return (base * 65535).astype(np.uint16)
    if dtype == "object":
        return base.astype(object)
    return base.astype(dtype)


def special_array(label, count, scalar):
    shape = (count,) if scalar else (count, 3)
    if label == "wrong_shape":
        return np.ones((count + 1, 2), np.float32)
    if label == "zeros":
        return np.zeros(shape, np.float32)
    array = np.ones(shape, np.float32)
    array.flat[0] = np.nan
    return array


def classify(error):
    if isinstance(error, PartialWrite):
        return "partial"
    if isinstance(error, Invalid):
        return "invalid"
    if isinstance(error, CLEAR_ERRORS) and str(error).strip():
        return "error"
    return "unclear"


def main():
    corpus, cases_file, first = sys.argv[1], sys.argv[2], int(sys.argv[3])
    sys.path.insert(0, os.environ.get("TEXSYNTH_MODULE_DIR") or os.path.join(
        os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))), "addon"))
    import texsynth_native
    cases = json.load(open(cases_file))
    runner = Runner(texsynth_native, corpus)
    try:
        for index in range(first, len(cases)):
            print(json.dumps({"start": index}), flush=True)
            try:
                detail, outcome = runner.run(cases[index]), "ok"
            except BaseException as error:  # noqa: B902 - everything is classified, nothing escapes
                outcome = classify(error)
                detail = "%s: %s" % (type(error).__name__, str(error).splitlines()[0] if str(error) else "")
            print(json.dumps({"index": index, "outcome": outcome, "detail": detail}), flush=True)
    finally:
        shutil.rmtree(runner.cache_dir, ignore_errors=True)


if __name__ == "__main__":
    main()
