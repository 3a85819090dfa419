# SPDX-License-Identifier: GPL-3.0-or-later
"""Turns workflow-soak reports (python_tests/blender/workflow_soak.py --report) into one markdown table
of per-operator counts per Blender version and one SVG memory curve per report.

    /usr/bin/python3.11 python_tests/bench/soak_report.py out/soak/workflow_*_10000.json \
        --out docs/benchmarks/workflow_soak.md

Plain Python (no numpy, no Blender): the SVG is written by hand so the report needs nothing installed.
"""
import argparse
import json
import os

OUTCOMES = ("finished", "failed", "undo", "redo", "rerun", "repeat", "branch", "skipped")


def load(paths):
    reports = []
    for path in paths:
        with open(path) as f:
            report = json.load(f)
        report["path"] = path
        reports.append(report)
    return sorted(reports, key=lambda r: [int(p) for p in r["blender"].split(".")[:2]])


def memory_svg(report, width=640, height=220, margin=44):
    """RSS (MB) against step, with the warm-up end and the bound the soak checks drawn in."""
    points = report["rss_kb"]
    memory = report["memory"]
    steps = [s for s, _ in points] or [0]
    mb = [kb / 1024.0 for _, kb in points] or [0.0]
    top = max(max(mb), memory["baseline_mb"] + memory["bound_mb"]) * 1.05
    last = max(steps[-1], 1)

    def x(step):
        return margin + (width - 2 * margin) * step / last

    def y(value):
        return height - margin + (2 * margin - height) * value / top

    stride = max(1, len(points) // 1500)  # enough points for the eye, a small file
    path = " ".join("%s%.1f,%.1f" % ("M" if i == 0 else "L", x(s), y(v))
                    for i, (s, v) in enumerate(zip(steps[::stride], mb[::stride])))
    bound = memory["baseline_mb"] + memory["bound_mb"]
    warm = memory["warmup_steps"]
    lines = [
        '<svg xmlns="http://www.w3.org/2000/svg" width="%d" height="%d" font-family="sans-serif" font-size="11">'
        % (width, height),
        '<rect width="100%" height="100%" fill="white"/>',
        '<text x="%d" y="16">Blender %s: resident memory over %d steps (seed %d)</text>'
        % (margin, report["blender"], report["steps"], report["seed"]),
        '<line x1="%d" y1="%d" x2="%d" y2="%d" stroke="black"/>' % (margin, height - margin, width - margin,
                                                                    height - margin),
        '<line x1="%d" y1="%d" x2="%d" y2="%d" stroke="black"/>' % (margin, margin, margin, height - margin),
        '<line x1="%.1f" y1="%.1f" x2="%.1f" y2="%.1f" stroke="#c33" stroke-dasharray="4 3"/>'
        % (x(0), y(bound), x(last), y(bound)),
        '<text x="%.1f" y="%.1f" fill="#c33">bound: baseline + %.0f MB</text>'
        % (x(last) - 150, y(bound) - 4, memory["bound_mb"]),
        '<line x1="%.1f" y1="%d" x2="%.1f" y2="%d" stroke="#888" stroke-dasharray="2 3"/>'
        % (x(warm), margin, x(warm), height - margin),
        '<text x="%.1f" y="%d" fill="#888">warm-up</text>' % (x(warm) + 3, margin + 10),
        '<path d="%s" fill="none" stroke="#25a" stroke-width="1"/>' % path,
    ]
    for fraction in (0, 0.5, 1):
        value = top * fraction
        lines.append('<text x="4" y="%.1f">%.0f MB</text>' % (y(value) + 4, value))
        step = int(last * fraction)
        lines.append('<text x="%.1f" y="%d" text-anchor="middle">%d</text>' % (x(step), height - margin + 14, step))
    lines.append('<text x="%d" y="%d" text-anchor="middle">step</text>' % (width // 2, height - 8))
    lines.append("</svg>")
    return "\n".join(lines) + "\n"


def markdown(reports, svg_names):
    out = ["| | " + " | ".join("Blender " + r["blender"] for r in reports) + " |",
           "|---|" + "---|" * len(reports)]

    def row(label, cells):
        out.append("| %s | %s |" % (label, " | ".join(cells)))

    row("steps (seed)", ["%d (%d)" % (r["steps"], r["seed"]) for r in reports])
    row("wall time", ["%.0f s" % r["seconds"] for r in reports])
    row("violations", [str(len(r["violations"])) for r in reports])
    row("findings", [str(len(r["findings"])) for r in reports])
    row("RSS start / end / max", ["%.0f / %.0f / %.0f MB" % (r["memory"]["start_mb"], r["memory"]["end_mb"],
                                                            r["memory"]["max_mb"]) for r in reports])
    row("growth after warm-up (bound)", ["%+.1f MB (%.0f)" % (r["memory"]["growth_mb"], r["memory"]["bound_mb"])
                                        for r in reports])
    operators = sorted({op for r in reports for op in r["counts"]})
    out += ["", "Per operator: steps, then the outcomes (finished, failed = refused with a report and nothing "
            "changed, undo, redo, rerun = same inputs again, repeat, branch = a new step after an undo).", "",
            "| operator | " + " | ".join("Blender " + r["blender"] for r in reports) + " |",
            "|---|" + "---|" * len(reports)]
    for op in operators:
        cells = []
        for r in reports:
            c = r["counts"].get(op, {})
            parts = ["%d %s" % (c[k], k) for k in OUTCOMES if c.get(k)]
            cases = sum(1 for k in c if k.startswith("case:"))
            if cases:
                parts.append("%d kinds of bad input" % cases)
            cells.append("**%d**: %s" % (c.get("steps", 0), ", ".join(parts)) if c else "-")
        row(op, cells)
    out.append("")
    for r, name in zip(reports, svg_names):
        out.append("![Blender %s memory curve](%s)" % (r["blender"], name))
        out.append("")
    return "\n".join(out)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("reports", nargs="+")
    parser.add_argument("--out", required=True, help="markdown file; the SVGs go next to it")
    args = parser.parse_args()
    reports = load(args.reports)
    folder = os.path.dirname(os.path.abspath(args.out))
    stem = os.path.splitext(os.path.basename(args.out))[0]
    names = []
    for r in reports:
        name = "%s_%s.svg" % (stem, r["blender"].split()[0].replace(".", "_"))
        with open(os.path.join(folder, name), "w") as f:
            f.write(memory_svg(r))
        names.append(name)
    table = markdown(reports, names)
    marker = "<!-- soak table -->"
    text = open(args.out).read() if os.path.exists(args.out) else marker + "\n"
    if marker not in text:
        text += "\n" + marker + "\n"
    head, _, tail = text.partition(marker)
    tail = tail.split("<!-- end soak table -->", 1)[-1] if "<!-- end soak table -->" in tail else ""
    with open(args.out, "w") as f:
        f.write(head + marker + "\n" + table + "\n<!-- end soak table -->" + tail)
    print(table)


if __name__ == "__main__":
    main()
