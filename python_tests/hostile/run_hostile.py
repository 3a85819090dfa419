# SPDX-License-Identifier: GPL-3.0-or-later
"""Runs the hostile corpus against texsynth_native in a worker subprocess with a time bound per case.

    python3.11 python_tests/hostile/run_hostile.py [CORPUS_DIR]   # generates the corpus if needed

A crash (the worker dies) or a hang (no answer within the case's timeout: the worker is killed) is
recorded against the case that was running, and a fresh worker continues with the next case.
Prints the counts and every failing case; exit status 1 when any case failed.
"""
import collections
import json
import os
import selectors
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
PYTHON = sys.executable  # the interpreter the module was built for: the one running the tests
DEFAULT_TIMEOUT = 60.0
FAILURES = ("crash", "hang", "partial", "invalid", "unclear", "unexpected")


def native_worker(corpus, cases_file):
    return lambda first: [PYTHON, os.path.join(HERE, "worker.py"), corpus, cases_file, str(first)]


def run_cases(corpus, cases_file, cases, command=None):
    """Returns one dict per case: index, id, outcome (ok | error | crash | hang | partial | ...), detail.
    command(first_index) -> argv of a worker that runs cases[first_index:] printing JSON lines
    (default: worker.py on texsynth_native); other output lines are ignored."""
    command = command or native_worker(corpus, cases_file)
    results, index = {}, 0
    while index < len(cases):
        worker = subprocess.Popen(command(index), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, cwd=HERE, text=True,
                                  errors="replace")
        output = []
        selector = selectors.DefaultSelector()
        selector.register(worker.stdout, selectors.EVENT_READ)
        running, started = None, time.monotonic()
        while True:
            limit = cases[running].get("timeout", DEFAULT_TIMEOUT) if running is not None else DEFAULT_TIMEOUT
            if not selector.select(timeout=max(0.0, limit - (time.monotonic() - started))):
                worker.kill()
                worker.wait()
                stuck = running if running is not None else index  # None: hung before its first case
                results[stuck] = dict(outcome="hang", detail="no answer after %.0f s: %s" % (limit, "".join(output)[-600:]))
                index = stuck + 1
                break
            line = worker.stdout.readline()
            if not line:  # worker exited
                code = worker.wait()
                if running is not None and running not in results:
                    tail = "".join(output[-12:])[-1200:]
                    results[running] = dict(outcome="crash", detail="worker exited with %s: %s" % (code, tail))
                    index = running + 1
                elif running is None:  # died before its first case: nothing more can run
                    results[index] = dict(outcome="crash", detail="worker failed to start: %s" % "".join(output)[-1200:])
                    index += 1
                else:
                    index = len(cases)
                break
            if not line.startswith("{"):
                output.append(line)
                continue
            message = json.loads(line)
            if "start" in message:
                running, started = message["start"], time.monotonic()
            else:
                results[message["index"]] = dict(outcome=message["outcome"], detail=message["detail"])
        selector.close()
    out = []
    for i, case in enumerate(cases):
        r = dict(results.get(i, dict(outcome="crash", detail="never ran")), index=i, id=case["id"])
        if r["outcome"] in ("ok", "error") and case["expect"] != "either" and r["outcome"] != case["expect"]:
            r["detail"] = "expected %s, got %s (%s)" % (case["expect"], r["outcome"], r["detail"])
            r["outcome"] = "unexpected"
        out.append(r)
    return out


def summary(results):
    counts = collections.Counter(r["outcome"] for r in results)
    line = "hostile native: %d cases run: %d ok, %d clear errors; crashes %d, hangs %d, partial writes %d, " \
           "invalid results %d, unclear errors %d, unexpected outcomes %d" % (
               len(results), counts["ok"], counts["error"], counts["crash"], counts["hang"], counts["partial"],
               counts["invalid"], counts["unclear"], counts["unexpected"])
    return line, counts


def main():
    sys.path.insert(0, HERE)
    import make_corpus
    corpus = sys.argv[1] if len(sys.argv) > 1 else tempfile.mkdtemp(prefix="texsynth_hostile_")
    cases_file = os.path.join(corpus, "cases.json")
    if not os.path.exists(cases_file):
        sys.path.insert(0, os.environ.get("TEXSYNTH_MODULE_DIR") or os.path.join(os.path.dirname(
            os.path.dirname(HERE)), "addon"))
        import texsynth_native
        make_corpus.generate(corpus, texsynth_native)
    cases = json.load(open(cases_file))
    results = run_cases(corpus, cases_file, cases)
    verbose = "-v" in sys.argv
    for r in results:
        if r["outcome"] in FAILURES or verbose:
            print("%-10s %s: %s" % (r["outcome"], r["id"], r["detail"]))
    line, counts = summary(results)
    print(line)
    return 1 if any(counts[f] for f in FAILURES) else 0


if __name__ == "__main__":
    sys.exit(main())
