# SPDX-License-Identifier: GPL-3.0-or-later
"""Two builds of texsynth_native timed in the same run (the benchmarks' --baseline DIR): each run in its
own process (a module name imports once per process), the builds alternating so that the machine's load
drifts the same way for both."""
import json
import subprocess


def run_alternating(builds, repeat, command_for):
    """builds: [(name, module directory)]; command_for(directory) -> argv of one run, which prints its figures
    as JSON lines. Returns {name: [parsed JSON objects, in run order]}."""
    runs = {name: [] for name, _ in builds}
    for index in range(repeat):
        for name, directory in (builds if index % 2 == 0 else builds[::-1]):
            lines = subprocess.run(command_for(directory), check=True, capture_output=True,
                                   text=True).stdout.splitlines()
            runs[name] += [json.loads(line) for line in lines if line.startswith("{")]
    return runs
