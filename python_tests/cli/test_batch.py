# SPDX-License-Identifier: GPL-3.0-or-later
"""The batch runner (addon/texsynth_batch.py) on a real Dask cluster of separate dask-scheduler and
dask-worker processes on 127.0.0.1: every method's outputs byte-identical to the CLI run job by job, a worker
killed mid-job, bad assets reported without stopping the batch, resume, and bad manifests refused."""
import csv
import json
import os
import signal
import subprocess
import sys
import threading
import time

import pytest

import addon_package
import blender_run
from scene_files import pebbles_png, write_grid_obj

BATCH = os.path.join(addon_package.ROOT, "addon", "texsynth_batch.py")
SAMPLES = blender_run.SAMPLES
PYTHON = "/usr/bin/python3"

if addon_package.blender_version()[0] == 3:  # the host (Debian 12): scripts/install_deps.sh installs Dask
    import distributed  # noqa: F401
else:  # the Blender 4.3 / 5.2 root filesystems carry Blender, not the batch runner's Dask
    pytest.importorskip("distributed", reason="the batch runner runs with the host's Python and Dask")



def load_batch():
    import importlib.util
    spec = importlib.util.spec_from_file_location("texsynth_batch", BATCH)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def jobs_for_every_method(folder):
    """Eight small jobs over the five methods, each baking a 64² image through the grid's UV map."""
    grid = str(write_grid_obj(folder / "grid.obj", cells=8))
    pebbles = pebbles_png(folder / "pebbles.png")
    common = ["--bake-size", "64", "--bake-margin", "2"]
    specs = [
        ("jumpmap-0", ["--sample", os.path.join(SAMPLES, "bricks.png"), "--method", "jumpmap", "--seed", "0"]),
        ("jumpmap-1", ["--sample", os.path.join(SAMPLES, "moss.png"), "--method", "jumpmap", "--seed", "1"]),
        ("texton-0", ["--sample", os.path.join(SAMPLES, "bricks.png"), "--method", "texton", "--seed", "0"]),
        ("texton-1", ["--sample", os.path.join(SAMPLES, "bark.png"), "--method", "texton", "--seed", "2"]),
        ("round", ["--sample", os.path.join(SAMPLES, "bark.png"), "--method", "round", "--scale", "2"]),
        ("patches", ["--sample", os.path.join(SAMPLES, "bricks.png"), "--method", "patches", "--scale", "2"]),
        ("particles-0", ["--sample", pebbles, "--method", "particles", "--classes", "3", "--blur", "0",
                         "--scale", "1.5", "--seed", "0"]),
        ("particles-1", ["--sample", pebbles, "--method", "particles", "--classes", "3", "--blur", "0",
                         "--scale", "1.5", "--seed", "3"]),
    ]
    return [{"name": name, "input": grid, "args": args + common,
             "outputs": {"bake": "out/%s.png" % name, "stats": "out/%s.json" % name}} for name, args in specs]


def write_manifest(folder, jobs):
    path = folder / "manifest.json"
    path.write_text(json.dumps({"jobs": jobs}))
    return str(path)


def run_batch(*args, timeout=1200):
    return subprocess.run([PYTHON, BATCH, "run"] + list(args), capture_output=True, text=True, timeout=timeout)


def staged_files(folder):
    return [os.path.join(d, f) for d, _, files in os.walk(folder) for f in files if ".texsynth-partial-" in d]


@pytest.mark.needs_native
def test_every_method_on_two_workers_matches_the_cli_job_by_job(tmp_path):
    jobs = jobs_for_every_method(tmp_path)
    manifest = write_manifest(tmp_path, jobs)
    process = run_batch(manifest, "--workers", "2", "--out", str(tmp_path / "report"))
    assert process.returncode == 0, process.stdout[-3000:] + process.stderr[-3000:]
    summary = json.loads((tmp_path / "report" / "summary.json").read_text())
    assert [job["name"] for job in summary["jobs"]] == [job["name"] for job in jobs]  # manifest order
    assert all(job["status"] == "ok" and job["attempts"] == 1 for job in summary["jobs"]), summary
    assert (tmp_path / "report" / "summary.html").read_text().count("<img ") == len(jobs)
    assert staged_files(tmp_path) == []
    # The same jobs one by one with the CLI: byte-identical images.
    for job in jobs:
        alone = tmp_path / "alone" / (job["name"] + ".png")
        alone.parent.mkdir(exist_ok=True)
        cli = blender_run.cli(*job["args"], "--mesh", job["input"], "--bake", str(alone))
        assert cli.returncode == 0, cli.stdout[-2000:] + cli.stderr[-2000:]
        batch = tmp_path / "out" / (job["name"] + ".png")
        assert batch.read_bytes() == alone.read_bytes(), job["name"]
    # Resume: nothing to do, and it says so; touching one input reruns only the jobs that read it.
    again = run_batch(manifest, "--workers", "1", "--out", str(tmp_path / "report"))
    assert again.returncode == 0 and "8 job(s), 0 to run, 8 up to date" in again.stdout, again.stdout
    os.utime(jobs[6]["args"][1])  # the pebbles sample of the two particle jobs
    again = run_batch(manifest, "--workers", "1", "--out", str(tmp_path / "report"))
    assert again.returncode == 0 and "8 job(s), 2 to run, 6 up to date" in again.stdout, again.stdout


@pytest.mark.needs_native
def test_a_worker_killed_mid_job_has_its_job_rerun_and_leaves_nothing_half_written(tmp_path):
    import psutil
    jobs = jobs_for_every_method(tmp_path)[:4]
    manifest = write_manifest(tmp_path, jobs)
    killed = []

    def kill_a_worker():
        deadline = time.time() + 300
        while time.time() < deadline and not killed:
            for proc in psutil.process_iter(["name", "cmdline"]):
                try:
                    cmdline = " ".join(proc.info["cmdline"] or [])
                    if "texsynth_cli.py" in cmdline and str(tmp_path) in cmdline:
                        worker = proc.parent()
                        if worker is not None and "python" in (worker.name() or ""):
                            time.sleep(1.0)  # the job is running: its outputs are being staged
                            os.kill(worker.pid, signal.SIGKILL)
                            killed.append(worker.pid)
                            return
                except (psutil.NoSuchProcess, psutil.AccessDenied):
                    continue
            time.sleep(0.2)

    killer = threading.Thread(target=kill_a_worker, daemon=True)
    killer.start()
    process = run_batch(manifest, "--workers", "2", "--out", str(tmp_path / "report"))
    killer.join(10)
    assert killed, "no worker was killed"
    assert process.returncode == 0, process.stdout[-3000:] + process.stderr[-3000:]
    summary = json.loads((tmp_path / "report" / "summary.json").read_text())
    assert all(job["status"] == "ok" for job in summary["jobs"]), summary
    assert sum(job["attempts"] for job in summary["jobs"]) >= len(jobs) + 1, summary  # the retry is counted
    assert all(os.path.isfile(path) for job in jobs for path in
               [tmp_path / p for p in job["outputs"].values()])
    assert staged_files(tmp_path) == []


@pytest.mark.needs_native
def test_bad_assets_are_reported_and_the_others_complete(tmp_path):
    jobs = jobs_for_every_method(tmp_path)[:2]
    corrupt = tmp_path / "corrupt.blend"
    corrupt.write_bytes(b"BLENDER-v300" + os.urandom(2000))
    jobs.append({"name": "corrupt", "input": str(corrupt), "args": ["--sample", os.path.join(SAMPLES, "bricks.png"),
                                                                    "--object", "Cube"],
                 "outputs": {"save": "out/corrupt.blend"}})
    jobs.append({"name": "bad flags", "input": jobs[0]["input"],
                 "args": ["--sample", os.path.join(SAMPLES, "bricks.png"), "--method", "jumpmap", "--classes", "3"],
                 "outputs": {"save": "out/bad.blend"}})
    process = run_batch(write_manifest(tmp_path, jobs), "--workers", "2", "--retries", "0",
                        "--out", str(tmp_path / "report"))
    assert process.returncode == 1, process.stdout[-3000:] + process.stderr[-3000:]
    assert "2 ok, 2 failed (corrupt, bad flags)" in process.stdout, process.stdout
    summary = {job["name"]: job for job in json.loads((tmp_path / "report" / "summary.json").read_text())["jobs"]}
    assert summary["bad flags"]["status"] == "failed" and "--classes is for --method particles" in \
        summary["bad flags"]["error"], summary["bad flags"]
    assert summary["corrupt"]["status"] == "failed" and summary["corrupt"]["error"], summary["corrupt"]
    assert not (tmp_path / "out" / "corrupt.blend").exists() and not (tmp_path / "out" / "bad.blend").exists()


def test_manifests_that_cannot_run_are_refused_before_anything_starts(tmp_path):
    batch = load_batch()
    mesh = write_grid_obj(tmp_path / "a.obj")
    write_grid_obj(tmp_path / "b.obj")
    good = {"input": "a.obj", "args": ["--sample", "s.png"], "outputs": {"save": "out/a.blend"}}
    cases = [
        ([good, {"input": "a.obj", "args": "--sample s.png", "outputs": {"save": "x.blend"}}],
         "job 1: args must be a list of strings"),
        ([good, {"input": "a.obj", "args": [], "outputs": {"movie": "x.mp4"}}], "job 1: unknown output 'movie'"),
        ([good, {"input": "a.obj", "args": ["--save", "x.blend"], "outputs": {"save": "y.blend"}}],
         "job 1: --save belongs in outputs"),
        ([good, {"input": "missing.obj", "args": [], "outputs": {"save": "m.blend"}}], "missing input file(s): "),
        ([good, dict(good, input="b.obj")], "both write "),
        ([{"glob": "*.nothing", "args": [], "outputs": {"save": "{stem}.blend"}}], "job 0: glob '*.nothing' matches"),
        ([], "non-empty list of jobs"),
    ]
    for jobs, fragment in cases:
        path = write_manifest(tmp_path, jobs)
        with pytest.raises(batch.ManifestError, match=None) as refused:
            batch.load_manifest(path)
        assert fragment in str(refused.value), (fragment, str(refused.value))
    # A glob job expands per file; a CSV row per job, its args split like a shell.
    expanded = batch.load_manifest(write_manifest(tmp_path, [
        {"glob": "*.obj", "args": ["--seed", "1"], "outputs": {"bake": "out/{stem}.png"}}]))
    assert [os.path.basename(j["outputs"]["bake"]) for j in expanded] == ["a.png", "b.png"]
    with open(tmp_path / "jobs.csv", "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(["input", "args", "save", "render", "bake", "stats"])
        writer.writerow(["a.obj", "--sample 'my sample.png' --seed 2", "out/a.blend", "", "", ""])
    (job,) = batch.load_manifest(str(tmp_path / "jobs.csv"))
    assert job["args"] == ["--sample", "my sample.png", "--seed", "2"] and job["input"] == str(mesh)
    # Nothing ran: a refused manifest exits 2 with one line.
    process = run_batch(write_manifest(tmp_path, [good, dict(good, input="b.obj")]), "--out", str(tmp_path / "r"))
    assert process.returncode == 2 and "both write" in process.stderr and not (tmp_path / "out").exists()


def test_an_unreachable_scheduler_is_a_clear_error_within_ten_seconds(tmp_path):
    write_grid_obj(tmp_path / "a.obj")
    manifest = write_manifest(tmp_path, [{"input": "a.obj", "args": [], "outputs": {"save": "out/a.blend"}}])
    started = time.time()
    process = run_batch(manifest, "--scheduler", "tcp://127.0.0.1:9", "--out", str(tmp_path / "r"), timeout=120)
    assert process.returncode == 2 and "cannot reach the Dask scheduler at tcp://127.0.0.1:9" in process.stderr, \
        process.stderr[-2000:]
    print("[ measured ] unreachable scheduler reported in %.1f s" % (time.time() - started), file=sys.stderr)
