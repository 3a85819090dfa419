# SPDX-License-Identifier: GPL-3.0-or-later
"""Batch synthesis on Dask: many TexSynth CLI runs, on one machine or a cluster. Runs with the system Python,
outside Blender (Debian: python3-distributed).

  python3 addon/texsynth_batch.py run MANIFEST.json|.csv [--scheduler tcp://HOST:PORT] [--workers N]
      [--retries K] [--out DIR] [--force] [--blender PATH] [--timeout SECONDS]

Without --scheduler a local cluster is started on 127.0.0.1: a dask-scheduler and N dask-worker processes
(default one per 2 cores), each running one `blender -b` at a time. With --scheduler the jobs go to an
existing cluster, whose workers need Blender and TexSynth installed and the manifest's files at the same
paths (a shared file system).

The manifest, JSON: {"jobs": [...]} or a list of jobs, each
  {"input": "rock.obj" | "scene.blend", "args": ["--sample", "moss.png", ...], "outputs": {"save": "out/rock.blend"}}
or {"glob": "meshes/*.obj", "args": [...], "outputs": {"bake": "out/{stem}.png"}} for one job per matching file
({stem}, {name}: the file's name without and with its extension). "args" are the CLI's flags as texsynth_cli.py
takes them; a mesh input is passed as --mesh, a .blend is opened (name the objects with --object). "outputs"
maps the CLI's output flags without dashes (save, render, bake, stats) to paths. CSV: one job per row, columns
input, args (one string, split like a shell), save, render, bake, stats. Relative paths are relative to the
manifest's folder.

Each job is one Blender process. Its outputs are written into a hidden staging folder next to them and moved
into place only when the job succeeded, so a killed job leaves no half-written file; a failed job is retried
up to --retries times, and a worker that dies mid-job has its job run elsewhere. A rerun skips the jobs whose
outputs exist and whose inputs (path, size, modification time), arguments and TexSynth version match the
recorded ones (--force reruns them). At the end: DIR/summary.json (one entry per job, in manifest order) and
DIR/summary.html (a table and the renders' contact sheet); the exit code is 1 when a job failed.
"""
import argparse
import csv
import glob
import hashlib
import html
import json
import os
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import uuid

HERE = os.path.dirname(os.path.abspath(__file__))
CLI = os.path.join(HERE, "texsynth_cli.py")
OUTPUT_FLAGS = ("save", "render", "bake", "stats")
MESH_EXTENSIONS = (".obj", ".ply", ".stl")
RECORDS = ".texsynth-batch"  # inside --out: one record per finished job, for resume
STAGING = ".texsynth-partial-"
LAST_LINES = 20


class ManifestError(ValueError):
    """The manifest cannot be run; the message names the job (index from 0) and what is wrong."""


class BatchError(RuntimeError):
    """The batch cannot start (cluster, Blender); nothing ran."""


# ---------------------------------------------------------------------------------------------
# The manifest


def _job_from(entry, index, base):
    if not isinstance(entry, dict):
        raise ManifestError("job %d: a job is an object with input, args and outputs, got %r" % (index, entry))
    unknown = sorted(set(entry) - {"input", "args", "outputs", "glob", "name"})
    if unknown:
        raise ManifestError("job %d: unknown field(s) %s" % (index, ", ".join(unknown)))
    args = entry.get("args", [])
    if not isinstance(args, list) or not all(isinstance(a, str) for a in args):
        raise ManifestError("job %d: args must be a list of strings (the CLI's flags), got %r" % (index, args))
    reserved = sorted({a.lstrip("-").split("=")[0] for a in args} & set(OUTPUT_FLAGS + ("mesh",)))
    if reserved:
        raise ManifestError("job %d: --%s belongs in outputs (or input), not in args" % (index, reserved[0]))
    outputs = entry.get("outputs", {})
    if not isinstance(outputs, dict) or not outputs:
        raise ManifestError("job %d: outputs must map at least one of %s to a path" % (index, ", ".join(OUTPUT_FLAGS)))
    bad = sorted(set(outputs) - set(OUTPUT_FLAGS))
    if bad:
        raise ManifestError("job %d: unknown output %r (outputs are %s)" % (index, bad[0], ", ".join(OUTPUT_FLAGS)))
    if not all(isinstance(p, str) and p for p in outputs.values()):
        raise ManifestError("job %d: output paths must be non-empty strings" % index)
    if "glob" in entry:
        if "input" in entry:
            raise ManifestError("job %d: give either input or glob, not both" % index)
        matches = sorted(glob.glob(os.path.join(base, entry["glob"])))
        if not matches:
            raise ManifestError("job %d: glob %r matches no file" % (index, entry["glob"]))
        jobs = []
        for path in matches:
            name = os.path.basename(path)
            stem = os.path.splitext(name)[0]
            jobs.append(dict(index=index, name="%s[%s]" % (entry.get("name", "job %d" % index), name), input=path,
                             args=list(args), outputs={k: os.path.join(base, v.format(stem=stem, name=name))
                                                       for k, v in outputs.items()}))
        return jobs
    if not isinstance(entry.get("input"), str) or not entry["input"]:
        raise ManifestError("job %d: input (a .blend or a mesh file) is missing" % index)
    return [dict(index=index, name=entry.get("name", "job %d" % index), input=os.path.join(base, entry["input"]),
                 args=list(args), outputs={k: os.path.join(base, v) for k, v in outputs.items()})]


def _csv_entries(path):
    entries = []
    with open(path, newline="") as handle:
        for row in csv.DictReader(handle):
            entry = {"input": (row.get("input") or "").strip(), "args": shlex.split(row.get("args") or "")}
            entry["outputs"] = {k: row[k].strip() for k in OUTPUT_FLAGS if (row.get(k) or "").strip()}
            entries.append(entry)
    return entries


def load_manifest(path):
    """The manifest's jobs, globs expanded, every path absolute; ManifestError for anything that cannot run:
    a malformed entry (named by index), missing input files (all listed), colliding output paths."""
    base = os.path.dirname(os.path.abspath(path))
    try:
        if path.lower().endswith(".csv"):
            entries = _csv_entries(path)
        else:
            with open(path) as handle:
                data = json.load(handle)
            entries = data.get("jobs") if isinstance(data, dict) else data
    except (OSError, ValueError, csv.Error) as error:
        raise ManifestError("manifest %s: %s" % (path, error)) from None
    if not isinstance(entries, list) or not entries:
        raise ManifestError("manifest %s: expected a non-empty list of jobs (or {\"jobs\": [...]})" % path)
    jobs = [job for index, entry in enumerate(entries) for job in _job_from(entry, index, base)]
    missing = sorted({job["input"] for job in jobs if not os.path.isfile(job["input"])})
    if missing:
        raise ManifestError("missing input file(s): %s" % ", ".join(missing))
    owners = {}
    for job in jobs:
        for flag, out in job["outputs"].items():
            key = os.path.normpath(out)
            if key in owners:
                raise ManifestError("%s and %s both write %s" % (owners[key], job["name"], out))
            owners[key] = "%s (%s)" % (job["name"], flag)
    return jobs


# ---------------------------------------------------------------------------------------------
# One job (runs on a worker)


def texsynth_version():
    """The add-on's version and the CLI's own bytes: a change of either reruns every job."""
    version = "unknown"
    try:
        with open(os.path.join(HERE, "blender_manifest.toml")) as handle:
            version = next(line.split("=", 1)[1].strip().strip('"') for line in handle if line.startswith("version"))
    except (OSError, StopIteration):
        pass
    with open(CLI, "rb") as handle:
        return "%s+%s" % (version, hashlib.sha256(handle.read()).hexdigest()[:12])


def job_key(job, version):
    """What a finished job's outputs depend on: its input and every file its arguments name (path, size,
    modification time), its arguments and outputs, and the TexSynth version."""
    files = [job["input"]] + [a for a in job["args"] if os.path.isfile(a)]
    stamp = []
    for path in files:
        info = os.stat(path)
        stamp.append((os.path.abspath(path), info.st_size, info.st_mtime_ns))
    text = json.dumps([stamp, job["args"], sorted(job["outputs"].items()), version])
    return hashlib.sha256(text.encode()).hexdigest()[:24]


def _die_with_parent():
    """The Blender child is killed when its worker dies (Linux), so a rescheduled job never races it."""
    try:
        import ctypes
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except OSError:
        pass


def command(job, staged, blender, cli=CLI):
    """The job's `blender -b` command line, its outputs going to the staged paths."""
    is_blend = job["input"].lower().endswith(".blend")
    cmd = [blender, "-b"] + ([job["input"]] if is_blend else []) + \
        ["--factory-startup", "--python-exit-code", "1", "--python", cli, "--"] + list(job["args"])
    if not is_blend:
        cmd += ["--mesh", job["input"]]
    for flag, path in sorted(staged.items()):
        cmd += ["--" + flag, path]
    return cmd


def run_job(job, blender, out_dir, key, timeout):
    """Runs one job in its own Blender; moves its outputs into place only when it succeeded. Returns a result
    dict (status ok | failed). Each attempt is counted in out_dir, so a rerun after a worker died shows."""
    attempts_path = os.path.join(out_dir, RECORDS, key + ".attempts")
    with open(attempts_path, "a") as handle:
        handle.write("%s\n" % os.getpid())
    attempt = uuid.uuid4().hex[:8]
    staging = {}
    staged = {}
    for flag, path in job["outputs"].items():
        folder = os.path.dirname(os.path.abspath(path))
        os.makedirs(folder, exist_ok=True)
        staging.setdefault(folder, os.path.join(folder, STAGING + key + "-" + attempt))
        os.makedirs(staging[folder], exist_ok=True)
        staged[flag] = os.path.join(staging[folder], os.path.basename(path))
    started = time.perf_counter()
    try:
        process = subprocess.run(command(job, staged, blender), capture_output=True, text=True, timeout=timeout,
                                 preexec_fn=_die_with_parent)
        code, stdout, stderr = process.returncode, process.stdout, process.stderr
    except subprocess.TimeoutExpired as error:
        code, stdout, stderr = -1, error.stdout or "", (error.stderr or "") + "\ntimed out after %d s" % timeout
        stdout = stdout.decode() if isinstance(stdout, bytes) else stdout
        stderr = stderr.decode() if isinstance(stderr, bytes) else stderr
    seconds = time.perf_counter() - started
    missing = [flag for flag, path in staged.items() if not os.path.isfile(path)]
    result = dict(name=job["name"], returncode=code, seconds=seconds, host=os.uname().nodename)
    if code == 0 and not missing:
        for flag, path in staged.items():
            os.replace(path, job["outputs"][flag])
        stats = None
        if "stats" in job["outputs"]:
            with open(job["outputs"]["stats"]) as handle:
                stats = json.load(handle)
        result.update(status="ok", stats=stats, error="")
    else:
        lines = (stdout + "\n" + stderr).strip().splitlines()
        why = "exit code %d" % code if code else "no %s written" % ", ".join(missing)
        result.update(status="failed", stats=None, error=why + ":\n" + "\n".join(lines[-LAST_LINES:]))
    for folder in staging.values():
        shutil.rmtree(folder, ignore_errors=True)
    return result


def _run_with_retries(job, blender, out_dir, key, timeout, retries):
    """run_job up to 1 + retries times while it fails (a bad asset is reported, never raised)."""
    for _ in range(retries + 1):
        result = run_job(job, blender, out_dir, key, timeout)
        if result["status"] == "ok":
            break
    return result


# ---------------------------------------------------------------------------------------------
# The cluster


class LocalCluster:
    """A dask-scheduler and `workers` dask-worker processes on 127.0.0.1 (the same commands a cluster runs),
    one task at a time per worker; stopped on exit."""

    def __init__(self, workers, folder):
        self.folder = folder
        self.file = os.path.join(folder, "scheduler.json")
        self.processes = []
        log = open(os.path.join(folder, "scheduler.log"), "w")
        self.processes.append(subprocess.Popen(
            [_tool("dask-scheduler"), "--host", "127.0.0.1", "--port", "0", "--dashboard-address", "127.0.0.1:0",
             "--scheduler-file", self.file], stdout=log, stderr=subprocess.STDOUT))
        deadline = time.time() + 60
        while not os.path.isfile(self.file) and time.time() < deadline:
            time.sleep(0.2)
        if not os.path.isfile(self.file):
            self.close()
            raise BatchError("the local dask-scheduler did not start (see %s)" % log.name)
        for n in range(workers):
            log = open(os.path.join(folder, "worker-%d.log" % n), "w")
            self.processes.append(subprocess.Popen(
                [_tool("dask-worker"), "--scheduler-file", self.file, "--nthreads", "1", "--nworkers", "1",
                 "--host", "127.0.0.1", "--name", "texsynth-%d" % n, "--local-directory", folder],
                stdout=log, stderr=subprocess.STDOUT))

    def close(self):
        for process in reversed(self.processes):
            if process.poll() is None:
                process.terminate()
        for process in self.processes:
            try:
                process.wait(10)
            except subprocess.TimeoutExpired:
                process.kill()


def _tool(name):
    found = shutil.which(name) or os.path.join(os.path.dirname(sys.executable), name)
    if not os.path.exists(found):
        raise BatchError("%s not found: install python3-distributed (Debian) or dask[distributed]" % name)
    return found


def _progress(done, failed, running, total, started, skipped):
    elapsed = time.time() - started
    finished = done + failed
    left = "" if not finished else ", about %d s left" % (elapsed / finished * (total - skipped - finished))
    bar = "#" * int(30 * (finished + skipped) / max(total, 1))
    sys.stderr.write("\r[%-30s] %d/%d done, %d failed, %d running%s   " % (bar, done + skipped, total, failed,
                                                                         running, left))
    sys.stderr.flush()


def run(manifest, out_dir, scheduler=None, workers=None, retries=1, force=False, blender="blender", timeout=3600):
    """Runs the manifest; returns the summary dict (also written to out_dir)."""
    jobs = load_manifest(manifest)
    out_dir = os.path.abspath(out_dir)
    os.makedirs(os.path.join(out_dir, RECORDS), exist_ok=True)
    version = texsynth_version()
    keys = [job_key(job, version) for job in jobs]
    results = [None] * len(jobs)
    todo = []
    for i, (job, key) in enumerate(zip(jobs, keys)):
        record = os.path.join(out_dir, RECORDS, key + ".json")
        if not force and os.path.isfile(record) and all(os.path.isfile(p) for p in job["outputs"].values()):
            with open(record) as handle:
                results[i] = dict(json.load(handle), status="ok", skipped=True)
        else:
            todo.append(i)
            attempts = os.path.join(out_dir, RECORDS, key + ".attempts")
            if os.path.exists(attempts):
                os.remove(attempts)
    skipped = len(jobs) - len(todo)
    print("texsynth_batch: %d job(s), %d to run, %d up to date" % (len(jobs), len(todo), skipped), flush=True)
    if todo:
        _run_jobs(jobs, keys, todo, results, out_dir, scheduler, workers, retries, blender, timeout, skipped)
    summary = {"jobs": []}
    for job, key, result in zip(jobs, keys, results):
        attempts_path = os.path.join(out_dir, RECORDS, key + ".attempts")
        attempts = sum(1 for _ in open(attempts_path)) if os.path.isfile(attempts_path) else 0
        entry = dict(name=job["name"], index=job["index"], input=job["input"], args=job["args"],
                     outputs=job["outputs"], status=result["status"], skipped=bool(result.get("skipped")),
                     attempts=result.get("attempts", attempts) if result.get("skipped") else attempts,
                     seconds=result.get("seconds"), stats=result.get("stats"), error=result.get("error", ""))
        summary["jobs"].append(entry)
        if result["status"] == "ok" and not result.get("skipped"):
            with open(os.path.join(out_dir, RECORDS, key + ".json"), "w") as handle:
                json.dump(dict(entry, skipped=False), handle)
    for folder in {os.path.dirname(os.path.abspath(p)) for job in jobs for p in job["outputs"].values()}:
        for stale in glob.glob(os.path.join(folder, STAGING + "*")):  # a killed worker's attempt
            shutil.rmtree(stale, ignore_errors=True)
    with open(os.path.join(out_dir, "summary.json"), "w") as handle:
        json.dump(summary, handle, indent=2)
    write_html(summary, os.path.join(out_dir, "summary.html"))
    return summary


def _run_jobs(jobs, keys, todo, results, out_dir, scheduler, workers, retries, blender, timeout, skipped):
    try:
        from distributed import Client, as_completed
    except ImportError:
        raise BatchError("Dask is not installed: apt install python3-distributed (Debian)") from None
    cluster = None
    try:
        if scheduler:
            try:
                client = Client(scheduler, timeout="10s")
            except (OSError, TimeoutError) as error:
                raise BatchError("cannot reach the Dask scheduler at %s within 10 s: %s" % (scheduler, error)) from None
        else:
            count = workers or max(1, (os.cpu_count() or 2) // 2)
            cluster = LocalCluster(count, tempfile.mkdtemp(prefix="texsynth-dask-"))
            client = Client(scheduler_file=cluster.file, timeout="60s")
            client.wait_for_workers(count, timeout=120)
        if client.dashboard_link:
            print("texsynth_batch: Dask dashboard %s" % client.dashboard_link, flush=True)
        futures = {}
        for i in todo:
            future = client.submit(_run_with_retries, jobs[i], blender, out_dir, keys[i], timeout, retries,
                                   key="texsynth-%s" % keys[i], pure=False)
            futures[future] = i
        done = failed = 0
        started = time.time()
        _progress(0, 0, len(todo), len(jobs), started, skipped)
        for future in as_completed(futures):
            i = futures[future]
            try:
                results[i] = future.result()
            except Exception as error:  # the task itself failed on every worker it reached
                results[i] = dict(status="failed", error="%s: %s" % (type(error).__name__, error), seconds=None)
            if results[i]["status"] == "ok":
                done += 1
            else:
                failed += 1
            _progress(done, failed, len(todo) - done - failed, len(jobs), started, skipped)
        sys.stderr.write("\n")
        client.close()
    finally:
        if cluster is not None:
            cluster.close()


def write_html(summary, path):
    """A table of the jobs and a contact sheet of their renders (thumbnails linking to the files)."""
    folder = os.path.dirname(path)
    rows, thumbs = [], []
    for job in summary["jobs"]:
        outputs = ", ".join('<a href="%s">%s</a>' % (html.escape(os.path.relpath(p, folder)), k)
                            for k, p in sorted(job["outputs"].items()))
        seconds = "" if job["seconds"] is None else "%.1f" % job["seconds"]
        rows.append("<tr class=%s><td>%s</td><td>%s%s</td><td>%d</td><td>%s</td><td>%s</td><td><pre>%s</pre></td></tr>"
                    % (job["status"], html.escape(job["name"]), job["status"], " (up to date)" if job["skipped"] else "",
                       job["attempts"], seconds, outputs, html.escape(job["error"][-2000:])))
        render = job["outputs"].get("render") or job["outputs"].get("bake")
        if render and job["status"] == "ok" and render.lower().endswith(".png"):
            thumbs.append('<figure><img src="%s" width=160><figcaption>%s</figcaption></figure>'
                          % (html.escape(os.path.relpath(render, folder)), html.escape(job["name"])))
    ok = sum(1 for j in summary["jobs"] if j["status"] == "ok")
    page = ("<!doctype html><meta charset=utf-8><title>TexSynth batch</title><style>body{font-family:sans-serif}"
            "td,th{border-bottom:1px solid #ccc;padding:4px;vertical-align:top}.failed{background:#fee}"
            "figure{display:inline-block;margin:4px}pre{margin:0;max-width:50em;white-space:pre-wrap}</style>"
            "<h1>TexSynth batch: %d of %d jobs ok</h1><table><tr><th>job</th><th>status</th><th>attempts</th>"
            "<th>seconds</th><th>outputs</th><th>error</th></tr>%s</table><h2>Renders</h2>%s"
            % (ok, len(summary["jobs"]), "".join(rows), "".join(thumbs) or "<p>none</p>"))
    with open(path, "w") as handle:
        handle.write(page)


def main(argv=None):
    parser = argparse.ArgumentParser(prog="texsynth_batch", description=__doc__.splitlines()[0])
    commands = parser.add_subparsers(dest="command", required=True)
    p = commands.add_parser("run", help="run a manifest of TexSynth CLI jobs")
    p.add_argument("manifest")
    p.add_argument("--scheduler", default=None, help="tcp://HOST:PORT of a running dask-scheduler")
    p.add_argument("--workers", type=int, default=None, help="local workers (default: one per 2 cores)")
    p.add_argument("--retries", type=int, default=1, help="reruns of a failing job (default 1)")
    p.add_argument("--out", default="batch-out", help="folder for summary.json, summary.html and resume records")
    p.add_argument("--force", action="store_true", help="rerun jobs whose outputs are up to date")
    p.add_argument("--blender", default="blender", help="Blender executable on the workers")
    p.add_argument("--timeout", type=float, default=3600, help="seconds before a job is stopped (default 3600)")
    args = parser.parse_args(argv)
    if args.retries < 0 or (args.workers is not None and args.workers < 1):
        parser.error("--retries must be >= 0 and --workers >= 1")
    try:
        summary = run(args.manifest, args.out, args.scheduler, args.workers, args.retries, args.force, args.blender,
                      args.timeout)
    except (ManifestError, BatchError) as error:
        print("texsynth_batch: error: %s" % error, file=sys.stderr)
        return 2
    failed = [job for job in summary["jobs"] if job["status"] != "ok"]
    print("texsynth_batch: %d ok, %d failed%s; summary in %s" % (
        len(summary["jobs"]) - len(failed), len(failed),
        (" (" + ", ".join(job["name"] for job in failed) + ")") if failed else "",
        os.path.join(args.out, "summary.json")), flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
