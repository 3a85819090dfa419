# SPDX-License-Identifier: GPL-3.0-or-later
"""Checks of README.md and docs/**/*.md: links resolve, README stays short, python blocks compile.

Plain Python: no Blender, no texsynth_native.
"""
import pathlib
import re
import textwrap

import pytest
import paths

ROOT = pathlib.Path(paths.ROOT)
README = ROOT / "README.md"
README_MAX_LINES = 250


def doc_files():
    return [README] + sorted((ROOT / "docs").rglob("*.md"))


def rel(path):
    return path.relative_to(ROOT).as_posix()


FENCE = re.compile(r"^\s*(```|~~~)")


def strip_code(text):
    """The text with fenced blocks and inline code spans blanked (links inside code are not links)."""
    out, in_fence = [], False
    for line in text.split("\n"):
        if FENCE.match(line):
            in_fence = not in_fence
            out.append("")
            continue
        out.append("" if in_fence else re.sub(r"`[^`]*`", "", line))
    return "\n".join(out)


# [text](target) and ![alt](target), target without spaces, optional "title"
LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\[\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")


def links(path):
    return LINK.findall(strip_code(path.read_text(encoding="utf-8")))


def slug(heading):
    """GitHub's anchor for a heading: lowercase, punctuation except - and space dropped, spaces -> -."""
    text = heading.strip().lower()
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(path):
    seen, result = {}, set()
    for line in strip_code(path.read_text(encoding="utf-8")).split("\n"):
        m = re.match(r"^#{1,6}\s+(.*?)\s*#*\s*$", line)
        if not m:
            continue
        base = slug(m.group(1))
        n = seen.get(base, 0)
        seen[base] = n + 1
        result.add(base if n == 0 else f"{base}-{n}")
    return result


def test_slug_rule():
    assert slug("Blender versions: 3.4, 4.3 and 5.2 LTS") == "blender-versions-34-43-and-52-lts"
    assert slug("Blending: histogram-preserving, seams removed at the edge") == \
        "blending-histogram-preserving-seams-removed-at-the-edge"
    assert slug("Round neighbourhoods (surface colour)") == "round-neighbourhoods-surface-colour"


def test_link_parser_finds_links_and_images():
    text = "see [a](x/y.md#z) and ![pic](p.jpg) but not `[c](nope.md)`"
    assert LINK.findall(strip_code(text)) == ["x/y.md#z", "p.jpg"]


def broken_links():
    broken = []
    for path in doc_files():
        for target in links(path):
            if re.match(r"^[a-zA-Z][a-zA-Z0-9+.-]*:", target):  # http:, https:, mailto:, ...
                continue
            file_part, _, anchor = target.partition("#")
            dest = (path.parent / file_part).resolve() if file_part else path
            if not dest.exists():
                broken.append(f"{rel(path)}: {target} (no file {file_part})")
                continue
            if anchor and dest.suffix == ".md" and anchor not in anchors(dest):
                broken.append(f"{rel(path)}: {target} (no heading #{anchor} in {dest.name})")
    return broken


def test_relative_links_and_images_resolve():
    broken = broken_links()
    assert not broken, "broken links:\n" + "\n".join(broken)


def test_readme_is_short():
    n = len(README.read_text(encoding="utf-8").splitlines())
    assert n <= README_MAX_LINES, f"README.md has {n} lines, at most {README_MAX_LINES}: move details into docs/"


def python_blocks(path):
    blocks, current, start = [], None, 0
    for i, line in enumerate(path.read_text(encoding="utf-8").split("\n"), 1):
        stripped = line.strip()
        if current is None:
            if stripped.startswith("```"):
                info = stripped[3:].strip().lower()
                current, start = ([] if info in ("python", "py") else "other"), i
        elif stripped.startswith("```"):
            if current != "other":
                blocks.append((start, "\n".join(current)))
            current = None
        elif current != "other":
            current.append(line)
    return blocks


def test_python_blocks_compile():
    errors = []
    for path in doc_files():
        for start, src in python_blocks(path):
            try:
                compile(textwrap.dedent(src), f"{rel(path)}:{start}", "exec")
            except SyntaxError as e:
                errors.append(f"{rel(path)}: block at line {start}: {e}")
    assert not errors, "python blocks that do not compile (fence fragments as ```text):\n" + "\n".join(errors)


@pytest.mark.parametrize("line", ["bash scripts/demo.sh", "bash scripts/test.sh"])
def test_readme_has_the_two_commands(line):
    lines = README.read_text(encoding="utf-8").splitlines()
    assert any(l.strip().startswith(line) for l in lines), f"README.md lacks the line `{line}`"
