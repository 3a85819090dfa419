# SPDX-License-Identifier: GPL-3.0-or-later
"""Every method at its default settings over the unseen corpus (issue 29), through the CLI. Not a test.

  /usr/bin/python3.11 python_tests/bench/corpus.py                 # once: out/corpus (samples, meshes, manifest)
  /usr/bin/python3.11 python_tests/bench/bench_corpus.py [--quick | --full] [--methods jumpmap,texton,...]
      [--samples NAME,...] [--meshes bunny,...] [--jobs 2] [--resume] [--out out/bench_corpus]
      [--docs docs/benchmarks] [--report-only]

Runs (default: the documented subset, FIRST_BUNNY / SUBSET_OTHER below; --quick: QUICK; --full: every sample x mesh): for each
sample x mesh x method one Blender process,

  blender -b <out>/empty.blend --python-exit-code 1 --python corpus_cli_shim.py --python addon/texsynth_cli.py
      --python corpus_measure.py -- --sample S --mesh M.obj --method METHOD --scale W/512 --seed 0
      --render render.png --resolution 480 360 --stats stats.json --cache-dir <out>/cache

i.e. the CLI with no option but the sample's scale (so every default: blending, levels, rings, candidates,
patch mode and size, particle classes, the 1024^2 image through an automatic UV map for round / patches, the
jump-map background for particles), then corpus_measure.py in the same process (its docstring defines the
figures). --scale = sample width / 512: 512 sample pixels per world unit on meshes whose longest side is
1 unit, the same texel density for every sample (a 64^2 pattern repeats 8 times across the bunny, a 2048^2
photo shows a quarter of its width). empty.blend: an empty scene, Eevee with 8 samples (the CLI adds a
camera and a sun). Results: <out>/runs/<mesh>/<sample>/<method>/ (cli.log, stats.json, render.png,
flat_front.png, flat_side.png, measure.json, run.json); then <docs>/corpus_results.{md,json} (one table) and
<docs>/sheet_<method>.jpg (per row: the whole sample, the sample at 1:1, the result at 1:1 from the front
measurement view, the CLI's Eevee render; the first 16 bunny samples and the other meshes, 60 px cells) and
<out>/sheets/sheet_<method>.jpg (every run, 96 px cells), written by corpus_sheets.py in Blender.

seconds = the CLI's stats `total` (preprocess + synthesis + transfer: what the artist waits for in
Synthesize); peak = the process' peak RSS after the CLI (synthesis and its Eevee render); wall = the whole
process (Blender start, CLI, render, measurement). $TEXSYNTH_MODULE_DIR, when set, is the folder whose
texsynth_native the add-on loads (a stable copy while others rebuild addon/).

A defaults sweep (docs/benchmarks/corpus.md "Round neighbourhoods: defaults swept on the corpus"): --cli-args adds CLI options to every
run, e.g. `--methods round --cli-args "--fine-rings 3" --out out/sweep/fine3 --docs out/sweep/fine3 --no-sheets`;
corpus_compare.py then sets its table beside the defaults'.
"""
import argparse
import json
import os
import shlex
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
METHODS = ("jumpmap", "texton", "round", "patches", "particles")
PX_PER_UNIT = 512
# The documented subset: every sample on the scanned bunny and 4 (one per category) on the three other meshes:
# (30 + 4 x 3) x 5 methods = 210 runs. Run in this order: 16 samples on the bunny (4 per category, 64^2 .. 2048^2,
# 4 grey), the 4 on the other meshes, then the other 14 samples on the bunny.
FIRST_BUNNY = ("parquet_basket", "paving_bricks", "marble_tiles_grey", "truchet_2048",
                "flagstones", "stone_wall", "leaf_veins_1024", "woven_facade_grey_1536",
                "gravel", "grass", "granite_grey", "meadow_1024",
                "cobbles", "leopard_spots", "fish_scales", "cups_1536")
SUBSET_OTHER = ("paving_bricks", "flagstones", "gravel", "cobbles")
QUICK = ("brick_small", "gravel", "cobbles", "flagstones")
# A run the defaults refused because faces are larger than the sample is run again with the option that
# message names (--allow-oversized), as "<method>+oversized", listed apart from the defaults' figures.
OVERSIZED = "+oversized"
OVERSIZED_ERROR = "faces are larger than the"


def parse_args():
    parser = argparse.ArgumentParser(prog="bench_corpus")
    parser.add_argument("--corpus", default=os.path.join(ROOT, "out", "corpus"))
    parser.add_argument("--out", default=os.path.join(ROOT, "out", "bench_corpus"))
    parser.add_argument("--docs", default=os.path.join(ROOT, "docs", "benchmarks"))
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--quick", action="store_true", help="4 samples on the bunny (20 runs)")
    group.add_argument("--full", action="store_true", help="every sample on every mesh (600 runs)")
    parser.add_argument("--methods", default=",".join(METHODS))
    parser.add_argument("--samples", default="", help="only these samples (comma-separated)")
    parser.add_argument("--meshes", default="", help="only these meshes (comma-separated)")
    parser.add_argument("--jobs", type=int, default=1, help="Blender processes at once")
    parser.add_argument("--resume", action="store_true", help="keep runs that already have a run.json")
    parser.add_argument("--timeout", type=float, default=1200.0, help="seconds per run")
    parser.add_argument("--report-only", action="store_true", help="only rebuild the table and the sheets")
    parser.add_argument("--blender", default=os.environ.get("TEXSYNTH_BLENDER", "blender"))
    parser.add_argument("--cli-args", default="", metavar="'--fine-rings 3 ...'",
                        help="CLI options added to every run: a defaults sweep (use its own --out and --docs)")
    parser.add_argument("--no-sheets", action="store_true", help="write the table only")
    args = parser.parse_args()
    args.out = os.path.abspath(args.out)  # Blender runs with other working folders
    args.methods = [m for m in args.methods.split(",") if m]
    unknown = set(args.methods) - set(METHODS)
    if unknown:
        parser.error("unknown methods: %s" % ", ".join(sorted(unknown)))
    return args


def load_manifest(corpus):
    path = os.path.join(corpus, "manifest.json")
    if not os.path.isfile(path):
        subprocess.run([sys.executable, os.path.join(HERE, "corpus.py"), "--out", corpus], check=True)
    with open(path) as handle:
        return json.load(handle)


def plan(args, manifest):
    samples = {s["name"]: s for s in manifest["samples"]}
    meshes = [m["name"] for m in manifest["meshes"]]
    only_samples = [s for s in args.samples.split(",") if s]
    only_meshes = [m for m in args.meshes.split(",") if m]
    for name in only_samples:
        if name not in samples:
            raise SystemExit("bench_corpus: no sample %r in the corpus" % name)
    pairs = []
    if args.full:
        pairs = [(s, m) for m in meshes for s in samples]
    elif args.quick:
        pairs = [(s, "bunny") for s in QUICK]
    else:
        pairs = ([(s, "bunny") for s in FIRST_BUNNY] + [(s, m) for m in meshes if m != "bunny" for s in SUBSET_OTHER]
                 + [(s, "bunny") for s in samples if s not in FIRST_BUNNY])
    if only_samples:
        pairs = [p for p in pairs if p[0] in only_samples] or [(s, m) for s in only_samples
                                                                 for m in (only_meshes or ["bunny"])]
    if only_meshes:
        pairs = [p for p in pairs if p[1] in only_meshes]
    return [(s, m, method) for s, m in pairs for method in args.methods], samples


def make_empty_blend(args):
    path = os.path.join(args.out, "empty.blend")
    if os.path.isfile(path):
        return path
    os.makedirs(args.out, exist_ok=True)  # Blender's save does not make folders, and still exits 0
    script = ("import bpy\n"
              "bpy.ops.wm.read_factory_settings(use_empty=True)\n"
              "scene = bpy.context.scene\n"
              "scene.render.engine = 'BLENDER_EEVEE'\n"
              "scene.eevee.taa_render_samples = 8\n"
              "bpy.ops.wm.save_as_mainfile(filepath=%r)\n" % path)
    subprocess.run([args.blender, "-b", "--factory-startup", "--python-expr", script], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    if not os.path.isfile(path):
        raise SystemExit("bench_corpus: Blender did not write %s" % path)
    return path


def run_dir(args, sample, mesh, method):
    return os.path.join(args.out, "runs", mesh, sample, method)


def start_run(args, empty, run, samples):
    sample, mesh, method = run
    folder = run_dir(args, sample, mesh, method)
    os.makedirs(folder, exist_ok=True)
    for name in ("run.json", "measure.json", "stats.json"):
        if os.path.exists(os.path.join(folder, name)):
            os.remove(os.path.join(folder, name))
    info = samples[sample]
    sample_path = os.path.join(args.corpus, info["file"])
    scale = info["width"] / float(PX_PER_UNIT)
    config = dict(sample=sample_path, method=method.split("+")[0], mesh=mesh, px_per_unit=PX_PER_UNIT, out=folder,
                  stats=os.path.join(folder, "stats.json"), seed=0, sample_size=[info["width"], info["height"]])
    with open(os.path.join(folder, "measure_config.json"), "w") as handle:
        json.dump(config, handle)
    command = [args.blender, "-b", empty, "--python-exit-code", "1",
               "--python", os.path.join(HERE, "corpus_cli_shim.py"),
               "--python", os.path.join(ROOT, "addon", "texsynth_cli.py"),
               "--python", os.path.join(HERE, "corpus_measure.py"), "--",
               "--sample", sample_path, "--mesh", os.path.join(args.corpus, "meshes", mesh + ".obj"),
               "--method", method.split("+")[0], "--scale", "%.6g" % scale, "--seed", "0",
               "--render", os.path.join(folder, "render.png"), "--resolution", "480", "360",
               "--stats", config["stats"], "--cache-dir", os.path.join(args.out, "cache")]
    if method.endswith(OVERSIZED):
        command.append("--allow-oversized")
    command += shlex.split(args.cli_args)
    env = dict(os.environ, TEXSYNTH_CORPUS_MEASURE=os.path.join(folder, "measure_config.json"))
    log = open(os.path.join(folder, "cli.log"), "w")
    log.write(" ".join(command) + "\n")
    log.flush()
    process = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT, env=env, cwd=ROOT)
    return dict(run=run, folder=folder, process=process, log=log, started=time.monotonic(),
                command=command, scale=scale)


def finish_run(job, status, rusage):
    job["log"].close()
    folder = job["folder"]
    sample, mesh, method = job["run"]
    error = ""
    with open(os.path.join(folder, "cli.log"), errors="replace") as handle:
        lines = handle.read().splitlines()
    for line in lines:
        if "texsynth_cli: error:" in line or line.startswith("corpus_measure:") and "no object" in line:
            error = line.strip()
    if status != 0 and not error:
        tail = [l for l in lines if l.strip() and not l.startswith(("Fra:", "EGL", "Blender quit"))]
        error = tail[-1].strip() if tail else "exit %s" % status
    record = dict(sample=sample, mesh=mesh, method=method, scale=job["scale"], exit=status, error=error,
                  wall=time.monotonic() - job["started"], process_peak_mb=rusage.ru_maxrss / 1024.0)
    with open(os.path.join(folder, "run.json"), "w") as handle:
        json.dump(record, handle, indent=1)
    return record


def oversized_retries(args, runs):
    retries = []
    for sample, mesh, method in runs:
        run = read_json(os.path.join(run_dir(args, sample, mesh, method), "run.json"))
        if run and run["exit"] != 0 and OVERSIZED_ERROR in run["error"] and method in METHODS:
            retries.append((sample, mesh, method + OVERSIZED))
    return retries


def execute(args, runs, samples):
    run_batch(args, runs, samples)
    retries = oversized_retries(args, runs)
    if retries:
        print("bench_corpus: %d runs refused oversized faces: again with --allow-oversized" % len(retries), flush=True)
        run_batch(args, retries, samples)


def run_batch(args, runs, samples):
    empty = make_empty_blend(args)
    todo = [r for r in runs if not (args.resume and os.path.isfile(os.path.join(run_dir(args, *r), "run.json")))]
    print("bench_corpus: %d runs (%d kept from before), %d at once" % (len(todo), len(runs) - len(todo), args.jobs),
          flush=True)
    active = {}
    done = 0
    started = time.monotonic()
    while todo or active:
        while todo and len(active) < args.jobs:
            job = start_run(args, empty, todo.pop(0), samples)
            active[job["process"].pid] = job
        pid, status, rusage = os.wait4(-1, 0)
        job = active.pop(pid, None)
        if job is None:
            continue
        code = os.waitstatus_to_exitcode(status)
        job["process"].returncode = code
        record = finish_run(job, code, rusage)
        done += 1
        print("bench_corpus: [%d/%d %.0f s] %s %s %s: %s" % (
            done, done + len(todo) + len(active), time.monotonic() - started, record["mesh"], record["sample"],
            record["method"], "ok %.0f s" % record["wall"] if code == 0 else "FAILED " + record["error"]),
            flush=True)
        for other in list(active.values()):  # the per-run time limit
            if time.monotonic() - other["started"] > args.timeout:
                other["process"].kill()


# ------------------------------------------------------------------------------------------ completeness

def _patches(image, ys, xs, k):
    import numpy as np
    oy, ox = np.mgrid[0:k, 0:k]
    return image[ys[:, None, None] + oy[None], xs[:, None, None] + ox[None]].reshape(len(ys), -1)


def completeness(folder, sample_path, own):
    """The other direction of the nearest-patch figure (bidirectional similarity, Simakov et al. 2008):
    400 random 7 x 7 RGB sample patches, each's mean squared distance per value to its nearest render patch
    (render windows whose 49 pixels are all measured, both views, a regular subset of at most 30,000), averaged,
    divided by the sample's own held-out figure (measure.json patch_sample). Blur, lost elements or a few
    repeated regions raise it: a sample patch then has no close counterpart in the result. Reads the saved
    flat_*.png and masks_*.png; cached in complete.json."""
    import numpy as np
    cached = read_json(os.path.join(folder, "complete.json"))
    if cached is not None:
        return cached.get("complete")
    sys.path.insert(0, os.environ.get("TEXSYNTH_MODULE_DIR", os.path.join(ROOT, "addon")))
    import texsynth_native
    k = 7
    windows = []
    for view in ("front", "side"):
        flat = os.path.join(folder, "flat_%s.png" % view)
        masks = os.path.join(folder, "masks_%s.png" % view)
        if not (os.path.isfile(flat) and os.path.isfile(masks)):
            return None
        rgb = np.asarray(texsynth_native.load_image(flat), np.float64)[..., :3]
        valid = np.asarray(texsynth_native.load_image(masks), np.float64)[..., 1] > 0.5
        h, w = valid.shape
        usable = np.ones((h - k + 1, w - k + 1), bool)
        for dy in range(k):
            for dx in range(k):
                usable &= valid[dy:dy + h - k + 1, dx:dx + w - k + 1]
        ys, xs = np.nonzero(usable)
        windows.append((rgb, ys, xs))
    total = sum(len(ys) for _, ys, _ in windows)
    if total < 20 or not own:
        return None
    stride = max(1, total // 30000)
    candidates = np.concatenate([_patches(rgb, ys[::stride], xs[::stride], k) for rgb, ys, xs in windows])
    sample = np.asarray(texsynth_native.load_image(sample_path), np.float64)
    sample = np.repeat(sample[..., :1], 3, 2) if sample.ndim == 3 and sample.shape[2] < 3 else (
        np.repeat(sample[..., None], 3, 2) if sample.ndim == 2 else sample[..., :3])
    rng = np.random.default_rng(2929)
    qy = rng.integers(0, sample.shape[0] - k + 1, 400)
    qx = rng.integers(0, sample.shape[1] - k + 1, 400)
    queries = _patches(sample, qy, qx, k)
    cand_sq = (candidates ** 2).sum(1)
    best = []
    for start in range(0, len(queries), 100):
        q = queries[start:start + 100]
        d = (q ** 2).sum(1)[:, None] + cand_sq[None, :] - 2.0 * q @ candidates.T
        best.append(np.maximum(d.min(1), 0.0))
    value = float(np.concatenate(best).mean() / candidates.shape[1]) / own
    with open(os.path.join(folder, "complete.json"), "w") as handle:
        json.dump(dict(complete=value, render_windows=int(total)), handle)
    return value


# --------------------------------------------------------------------------------------------- the table

def read_json(path):
    try:
        with open(path) as handle:
            return json.load(handle)
    except (OSError, ValueError):
        return None


def collect(args, runs, samples):
    rows = []
    for sample, mesh, method in runs + oversized_retries(args, runs):
        folder = run_dir(args, sample, mesh, method)
        run = read_json(os.path.join(folder, "run.json"))
        if run is None:
            continue
        measure = read_json(os.path.join(folder, "measure.json")) or {}
        stats = read_json(os.path.join(folder, "stats.json")) or {}
        seconds = (stats.get("seconds") or {})
        density = measure.get("density") or {}
        info = samples[sample]
        complete = None
        if run["exit"] == 0 and measure:
            complete = completeness(folder, os.path.join(args.corpus, info["file"]), measure.get("patch_sample"))
        rows.append(dict(sample=sample, category=info["category"], size="%dx%d" % (info["width"], info["height"]),
                         colour=info["colour"], mesh=mesh, method=method.split("+")[0],
                         variant="allow-oversized" if method.endswith(OVERSIZED) else "", ok=run["exit"] == 0 and bool(measure),
                         error=run["error"] if run["exit"] else ("" if measure else "no measurement"),
                         seam=measure.get("seam"), detail=measure.get("detail"), patch=measure.get("patch"),
                         complete=complete, density=density.get("ratio") if density else None,
                         seconds=seconds.get("total"), render_seconds=seconds.get("render"), wall=run["wall"],
                         peak_mb=measure.get("peak_mb") or run.get("process_peak_mb"),
                         notes=[n for n in (stats.get("notes") or [])][:3],
                         folder=os.path.relpath(folder, ROOT)))
    return rows


def fmt(value, digits=2):
    return "–" if value is None else ("%.*f" % (digits, value))


def median(values):
    values = [v for v in values if v is not None]
    return statistics.median(values) if values else None


def summary_rows(rows):
    out = []
    for method in METHODS:
        mine = [r for r in rows if r["method"] == method and not r["variant"]]
        if not mine:
            continue
        ok = [r for r in mine if r["ok"]]
        out.append(dict(method=method, runs=len(mine), failed=len(mine) - len(ok),
                        seam=median([r["seam"] for r in ok]), detail=median([r["detail"] for r in ok]),
                        patch=median([r["patch"] for r in ok]), complete=median([r["complete"] for r in ok]),
                        density=median([r["density"] for r in ok]),
                        seconds=median([r["seconds"] for r in ok]),
                        peak_mb=max([r["peak_mb"] for r in ok if r["peak_mb"]] or [0]) or None,
                        seam_over_110=sum(1 for r in ok if r["seam"] is not None and r["seam"] > 1.10),
                        detail_under_075=sum(1 for r in ok if r["detail"] is not None and r["detail"] < 0.75),
                        patch_over_2=sum(1 for r in ok if r["patch"] is not None and r["patch"] > 2.0),
                        complete_over_2=sum(1 for r in ok if r["complete"] is not None and r["complete"] > 2.0)))
    return out


def category_rows(rows):
    out = []
    for method in METHODS:
        for category in ("regular", "near-regular", "stochastic", "element"):
            mine = [r for r in rows if r["method"] == method and r["category"] == category and r["ok"]
                    and not r["variant"]]
            if mine:
                out.append(dict(method=method, category=category, runs=len(mine),
                                seam=median([r["seam"] for r in mine]), detail=median([r["detail"] for r in mine]),
                                patch=median([r["patch"] for r in mine]),
                                complete=median([r["complete"] for r in mine])))
    return out


def write_table(args, rows):
    os.makedirs(args.docs, exist_ok=True)
    summary = summary_rows(rows)
    categories = category_rows(rows)
    def rounded(value):
        if isinstance(value, float):
            return float("%.4g" % value)
        if isinstance(value, dict):
            return {k: rounded(v) for k, v in value.items()}
        if isinstance(value, list):
            return [rounded(v) for v in value]
        return value
    # JSON: one run per line, 4 significant digits, without the run folder (out/bench_corpus/runs/<mesh>/<sample>/
    # <method>) and the report notes (in the markdown table)
    with open(os.path.join(args.docs, "corpus_results.json"), "w") as handle:
        handle.write('{"px_per_unit": %d,\n "summary": [\n  %s],\n "categories": [\n  %s],\n "runs": [\n  %s]}\n' % (
            PX_PER_UNIT, ",\n  ".join(json.dumps(rounded(x)) for x in summary),
            ",\n  ".join(json.dumps(rounded(x)) for x in categories),
            ",\n  ".join(json.dumps(rounded({k: v for k, v in x.items() if k not in ("folder", "notes")}))
                         for x in rows)))
    lines = ["# Corpus benchmark results", "",
             "Written by `python_tests/bench/bench_corpus.py` (definitions in its docstring and in "
             "`corpus_measure.py`; discussion in [corpus.md](corpus.md)). Every method at its defaults through "
             "`addon/texsynth_cli.py`, `--scale` = sample width / %d. seam: edge / interior gradient at "
             "discontinuities of the mapping (1.00 = invisible); detail: render gradient / the sample's; patch: "
             "nearest 7x7 patch distance, result -> sample, / the sample's own held-out figure; complete: the same, sample -> result (blur and lost structure raise it); density: particles per pixel / the "
             "sample's; s: the CLI's synthesis seconds (preprocess + synthesis + transfer); MB: peak RSS of "
             "the CLI process (synthesis and its Eevee render)." % PX_PER_UNIT, "",
             "## Per method (medians over its runs)", "",
             "| method | runs | failed | seam | detail | patch | complete | density | s | peak MB | seam > 1.10 | "
             "detail < 0.75 | patch > 2 | complete > 2 |", "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for s in summary:
        lines.append("| %s | %d | %d | %s | %s | %s | %s | %s | %s | %s | %d | %d | %d | %d |" % (
            s["method"], s["runs"], s["failed"], fmt(s["seam"]), fmt(s["detail"]), fmt(s["patch"]),
            fmt(s["complete"]), fmt(s["density"]), fmt(s["seconds"], 1), fmt(s["peak_mb"], 0), s["seam_over_110"],
            s["detail_under_075"], s["patch_over_2"], s["complete_over_2"]))
    lines += ["", "## Per method and category (medians)", "",
              "| method | category | runs | seam | detail | patch | complete |", "|---|---|---|---|---|---|---|"]
    for c in categories:
        lines.append("| %s | %s | %d | %s | %s | %s | %s |" % (c["method"], c["category"], c["runs"], fmt(c["seam"]),
                                                              fmt(c["detail"]), fmt(c["patch"]), fmt(c["complete"])))
    lines += ["", "## Every run", "",
              "| mesh | sample | category | size | method | seam | detail | patch | complete | density | s | MB | note |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in sorted(rows, key=lambda r: (r["mesh"] != "bunny", r["mesh"], r["sample"], METHODS.index(r["method"]),
                                         r["variant"])):
        note = r["error"] if not r["ok"] else "; ".join(r["notes"])
        note = note.replace("|", "/")
        if len(note) > 140:
            note = note[:137] + "..."
        lines.append("| %s | %s | %s | %s%s | %s | %s | %s | %s | %s | %s | %s | %s | %s |" % (
            r["mesh"], r["sample"], r["category"], r["size"], " grey" if r["colour"] == "grey" else "",
            r["method"] + (" (--allow-oversized)" if r["variant"] else ""),
            fmt(r["seam"]), fmt(r["detail"]), fmt(r["patch"]), fmt(r["complete"]), fmt(r["density"]),
            fmt(r["seconds"], 1),
            fmt(r["peak_mb"], 0), note))
    with open(os.path.join(args.docs, "corpus_results.md"), "w") as handle:
        handle.write("\n".join(lines) + "\n")
    print("bench_corpus: wrote %s" % os.path.join(args.docs, "corpus_results.md"))
    for s in summary:
        print("  %-9s runs %3d failed %2d seam %s detail %s patch %s complete %s density %s s %s peak %s MB" % (
            s["method"], s["runs"], s["failed"], fmt(s["seam"]), fmt(s["detail"]), fmt(s["patch"]), fmt(s["complete"]),
            fmt(s["density"]), fmt(s["seconds"], 1), fmt(s["peak_mb"], 0)))


def write_sheets(args, rows, samples):
    """Full sheets (every run, 96 px cells, quality 80) in <out>/sheets; small ones for docs/ (the first 16
    bunny samples and the 4 on the other meshes, defaults only, 60 px cells, quality 35: about 450 KB for all five)."""
    core = {(s, "bunny") for s in FIRST_BUNNY} | {(s, m) for s in SUBSET_OTHER for m in ("part", "elk", "anchor")}
    for folder, row_px, quality, keep in ((os.path.join(args.out, "sheets"), 96, 80, lambda r: True),
                                          (args.docs, 60, 35,
                                           lambda r: (r["sample"], r["mesh"]) in core and not r["variant"])):
        chosen = [r for r in rows if keep(r)]
        if not chosen:
            continue
        spec = dict(rows=[dict(sample=r["sample"], mesh=r["mesh"], method=r["method"], ok=r["ok"], seam=r["seam"],
                               variant=r["variant"],
                               detail=r["detail"], patch=r["patch"], complete=r["complete"], density=r["density"],
                               sample_file=os.path.join(args.corpus, samples[r["sample"]]["file"]),
                               folder=os.path.join(ROOT, r["folder"])) for r in chosen],
                    docs=folder, methods=list(METHODS), row=row_px, quality=quality)
        path = os.path.join(args.out, "sheets.json")
        with open(path, "w") as handle:
            json.dump(spec, handle)
        subprocess.run([args.blender, "-b", "--factory-startup", "--python-exit-code", "1", "--python",
                        os.path.join(HERE, "corpus_sheets.py"), "--", path], check=True, stdout=subprocess.DEVNULL)
        print("bench_corpus: contact sheets in %s" % folder)


def main():
    args = parse_args()
    manifest = load_manifest(args.corpus)
    runs, samples = plan(args, manifest)
    os.makedirs(args.out, exist_ok=True)
    if not args.report_only:
        execute(args, runs, samples)
    rows = collect(args, runs, samples)
    write_table(args, rows)
    if not args.no_sheets:
        write_sheets(args, rows, samples)


if __name__ == "__main__":
    main()
