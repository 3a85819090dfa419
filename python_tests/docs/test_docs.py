# SPDX-License-Identifier: GPL-3.0-or-later
"""Checks of README.md and docs/**/*.md: links resolve, README stays short, code blocks run.

Code blocks, by the info string of their fence:
- ```python: a runnable example. Each one runs in a fresh temporary folder, as written: in a subprocess of
  sys.executable with addon/ on sys.path, or, when it imports bpy, inside one `blender -b --factory-startup`
  for all such blocks with the add-on registered as `texsynth`. One pytest case per block, named
  "doc:line" of its opening fence; tracebacks show the doc's own line numbers. A block that names
  texsynth_native or imports the add-on is skipped when the native module is not built.
- ```python signature: a reference listing of calls (undefined names, not run; it must compile). GitHub
  highlights it as Python (the language is the info string's first word); a ```python example follows it.
- ```sh / ```bash: not run. Every scripts/, python_tests/, addon/ or blend_samples/ path a command names must
  exist, and every --option given to addon/texsynth_cli.py (after Blender's `--`) or addon/texsynth_batch.py
  must be one its parser accepts (read from the parser the entry point builds, see cli_options.py).
"""
import glob
import json
import os
import pathlib
import re
import shutil
import subprocess
import sys
import tempfile
import textwrap

import pytest

import addon_package
import blender_run
import cli_options
import paths

ROOT = pathlib.Path(paths.ROOT)
README = ROOT / "README.md"
README_MAX_LINES = 250
SIGNATURE = "python signature"  # the info string of a reference listing that is not run


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


class Block:
    """One fenced block: its doc, the line of its opening fence, its info string and its text."""

    def __init__(self, path, line, info, source):
        self.path, self.line, self.info, self.source = path, line, info, source
        self.name = "%s:%d" % (rel(path), line)

    def __repr__(self):
        return self.name


def fenced_blocks(path):
    blocks, current = [], None
    for i, line in enumerate(path.read_text(encoding="utf-8").split("\n"), 1):
        stripped = line.strip()
        if current is None:
            if stripped.startswith("```"):
                current = Block(path, i, " ".join(stripped[3:].split()).lower(), [])
        elif stripped.startswith("```"):
            current.source = textwrap.dedent("\n".join(current.source))
            blocks.append(current)
            current = None
        else:
            current.source.append(line)
    return blocks


def all_blocks(*infos):
    return [block for path in doc_files() for block in fenced_blocks(path) if block.info in infos]


# ---- Python blocks: every ```python block runs ----------------------------------------------------------

def uses_bpy(source):
    return re.search(r"^\s*(import\s+([\w.]+\s*,\s*)*bpy\b|from\s+bpy\b)", source, re.MULTILINE) is not None


def uses_native(source):
    """texsynth_native named, or the add-on imported (whose calls reach it)."""
    return "texsynth_native" in source or re.search(r"\b(import|from)\s+texsynth\b", source) is not None


def run_plain_block(name, line, source, cwd):
    """Runs source as a script with sys.executable in cwd, addon/ importable; returns CompletedProcess.
    Leading newlines make a traceback name the doc file at its own line numbers."""
    bootstrap = ("import sys\n"
                 "name, line, source = sys.argv[1], int(sys.argv[2]), sys.stdin.read()\n"
                 "exec(compile('\\n' * line + source, name.rsplit(':', 1)[0], 'exec'), {'__name__': '__main__'})\n")
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (os.environ.get("TEXSYNTH_MODULE_DIR"), paths.ADDON,
                                                     os.environ.get("PYTHONPATH")) if p)
    return subprocess.run([sys.executable, "-c", bootstrap, name, str(line)], input=source, cwd=str(cwd),
                          env=env, capture_output=True, text=True, timeout=blender_run.HANG_SECONDS)


def block_params(blocks):
    return [pytest.param(b, id=b.name, marks=[pytest.mark.needs_native] if uses_native(b.source) else [])
            for b in blocks]


PLAIN_BLOCKS = [b for b in all_blocks("python", "py") if not uses_bpy(b.source)]
BPY_BLOCKS = [b for b in all_blocks("python", "py") if uses_bpy(b.source)]


def test_python_blocks_compile():
    errors = []
    for block in all_blocks("python", "py", SIGNATURE):
        try:
            compile(block.source, block.name, "exec")
        except SyntaxError as e:
            errors.append(f"{block.name}: {e}")
    assert not errors, "python blocks that do not compile:\n" + "\n".join(errors)


def test_python_blocks_use_one_of_the_two_info_strings():
    """A variant (```python3, ```Python example) would be neither run nor compiled: refused."""
    odd = [f"{b.name}: ```{b.info}" for path in doc_files() for b in fenced_blocks(path)
           if b.info.startswith("py") and b.info not in ("python", "py", SIGNATURE)]
    assert not odd, "use ```python (runs) or ```%s (listing): %s" % (SIGNATURE, odd)


def test_signature_blocks_have_an_example_next_to_them():
    """A reference listing is not run, so a runnable ```python block must follow it on the same page."""
    lonely = []
    for path in doc_files():
        blocks = fenced_blocks(path)
        for i, block in enumerate(blocks):
            if block.info == SIGNATURE and not any(b.info == "python" for b in blocks[i + 1:i + 3]):
                lonely.append(block.name)
    assert not lonely, "```%s blocks without a ```python example after them: %s" % (SIGNATURE, lonely)


@pytest.mark.parametrize("block", block_params(PLAIN_BLOCKS))
def test_python_block_runs(block, tmp_path):
    process = run_plain_block(block.name, block.line, block.source, tmp_path)
    assert process.returncode == 0, "%s failed:\n%s%s" % (block.name, process.stdout[-3000:], process.stderr[-4000:])


def test_a_broken_block_fails_and_names_its_doc_line(tmp_path):
    good = run_plain_block("docs/x.md:10", 10, "open('out.txt', 'w').write('ok')\nprint('fine')\n", tmp_path)
    assert good.returncode == 0 and "fine" in good.stdout and (tmp_path / "out.txt").exists(), good.stderr
    bad = run_plain_block("docs/x.md:10", 10, "x = 1\nassert x == 2, 'planted'\n", tmp_path)
    assert bad.returncode != 0
    assert 'File "docs/x.md", line 12' in bad.stderr and "AssertionError: planted" in bad.stderr, bad.stderr


PLANTED = "raise RuntimeError('planted failure')\n"
_blender_runs = {}


def blender_blocks_run():
    """One Blender for every bpy block (plus a planted failing block, and the CLI's options for the sh
    checks): {name: (PASS|FAIL, lines)}, the CLI options (or None) and the whole output."""
    if "run" not in _blender_runs:
        if shutil.which(addon_package.BLENDER) is None:
            pytest.skip("no Blender (%s)" % addon_package.BLENDER)
        work = tempfile.mkdtemp(prefix="texsynth_doc_blocks_")
        blocks = [dict(name=b.name, file=rel(b.path), line=b.line, source=b.source) for b in BPY_BLOCKS
                  if addon_package.real_synthesizer_available() or not uses_native(b.source)]
        blocks.append(dict(name="planted:1", file="planted", line=1, source=PLANTED))
        listing = os.path.join(work, "blocks.json")
        with open(listing, "w") as f:
            json.dump(blocks, f)
        # Blender's user cache folder points into the temporary folder: examples keep the default cache_dir.
        process = blender_run.blender("--python", os.path.join(ROOT, "python_tests", "docs", "doc_blocks_blender.py"),
                                      "--", listing, env={"XDG_CACHE_HOME": os.path.join(work, "cache")})
        results, current, options = {}, None, None
        for line in process.stdout.splitlines():
            match = re.match(r"^BLOCK (PASS|FAIL) (\S+)$", line)
            if match:
                current = match.group(2)
                results[current] = (match.group(1), [])
            elif line.startswith("CLI_OPTIONS "):
                options = json.loads(line[len("CLI_OPTIONS "):])
            elif line.startswith("BLOCKS DONE"):
                current = None
            elif current is not None:
                results[current][1].append(line)
        _blender_runs["run"] = (results, options, process.stdout + process.stderr)
    return _blender_runs["run"]


@pytest.mark.parametrize("block", block_params(BPY_BLOCKS))
def test_bpy_block_runs_in_blender(block):
    results, _, output = blender_blocks_run()
    assert block.name in results, "Blender never reported %s:\n%s" % (block.name, output[-5000:])
    status, lines = results[block.name]
    assert status == "PASS", "%s failed inside Blender:\n%s" % (block.name, "\n".join(lines[-60:]))


def test_a_broken_bpy_block_fails_by_name():
    results, _, output = blender_blocks_run()
    assert "planted:1" in results, output[-5000:]
    status, lines = results["planted:1"]
    assert status == "FAIL" and "RuntimeError: planted failure" in "\n".join(lines), lines


# ---- sh blocks: named files exist, CLI options exist ----------------------------------------------------

# Files of this repository a command names (outputs under out/, build/, dist/ are made by the commands).
REPO_PATH = re.compile(r"(?<![\w./$<-])((?:scripts|python_tests|addon|blend_samples)/[\w./*-]*[\w*])")
OPTION = re.compile(r"(?<![\w-])(--[a-zA-Z][\w-]*)")
ENTRY_POINTS = {"texsynth_cli.py": "cli", "texsynth_batch.py": "batch"}


def shell_commands(source):
    """(line in the block, command): continuation lines joined, comments dropped."""
    commands, pending, first = [], "", None
    for i, line in enumerate(source.split("\n"), 1):
        code = re.sub(r"(^|\s)#.*$", "", line).rstrip()
        if first is None:
            first = i
        if code.endswith("\\"):
            pending += code[:-1] + " "
            continue
        text = (pending + code).strip()
        if text:
            commands.append((first, text))
        pending, first = "", None
    return commands


def missing_paths(source):
    return [path for _, command in shell_commands(source) for path in REPO_PATH.findall(command)
            if not glob.glob(os.path.join(ROOT, path))]


def entry_point_options(command):
    """(entry point, --options given to it) when command runs texsynth_cli.py or texsynth_batch.py: for
    `blender ... --python addon/texsynth_cli.py -- ARGS` only ARGS (before ` -- ` they are Blender's)."""
    for script, kind in ENTRY_POINTS.items():
        if script not in command:
            continue
        tail = command.split(script, 1)[1]
        if kind == "cli":
            if not re.search(r"(^|\s)--(\s|$)", tail):
                return kind, []
            tail = re.split(r"(?:^|\s)--(?:\s|$)", tail, maxsplit=1)[1]
        return kind, OPTION.findall(tail)
    return None, []


def unknown_options(source, accepted):
    """`--option`s given to an entry point that its parser does not accept: ["line N: --x (cli)", ...]."""
    unknown = []
    for line, command in shell_commands(source):
        kind, options = entry_point_options(command)
        unknown += ["line %d: %s (%s)" % (line, o, kind) for o in options if o not in accepted[kind]]
    return unknown


SH_BLOCKS = all_blocks("sh", "bash", "shell", "console")


@pytest.mark.parametrize("block", SH_BLOCKS, ids=[b.name for b in SH_BLOCKS])
def test_sh_block_names_files_that_exist(block):
    missing = missing_paths(block.source)
    assert not missing, "%s names files that do not exist: %s" % (block.name, missing)


CLI_SH_BLOCKS = [b for b in SH_BLOCKS if any(entry_point_options(c)[0] for _, c in shell_commands(b.source))]


@pytest.mark.parametrize("block", CLI_SH_BLOCKS, ids=[b.name for b in CLI_SH_BLOCKS])
def test_sh_block_gives_the_cli_only_options_it_accepts(block):
    _, cli, output = blender_blocks_run()
    assert cli, "could not read texsynth_cli's options inside Blender:\n" + output[-4000:]
    accepted = {"cli": set(cli), "batch": cli_options.texsynth_batch_options(paths.ADDON)}
    unknown = unknown_options(block.source, accepted)
    assert not unknown, "%s gives options its command does not accept: %s" % (block.name, unknown)


def test_sh_checks_catch_a_stale_path_and_option():
    source = ("bash scripts/demo.sh   # scripts/not_here.sh in a comment is ignored\n"
              "bash scripts/gone.sh\n"
              "blender -b s.blend --factory-startup --python addon/texsynth_cli.py -- --sample a.png \\\n"
              "    --object A --old-option 3 --bake out/x.png\n"
              "python3 addon/texsynth_batch.py run jobs.json --out report --nope\n")
    assert missing_paths(source) == ["scripts/gone.sh"]
    accepted = {"cli": {"--sample", "--object", "--bake"}, "batch": {"--out"}}
    assert unknown_options(source, accepted) == ["line 3: --old-option (cli)", "line 5: --nope (batch)"]


def test_batch_options_are_read_from_its_parser():
    assert {"--scheduler", "--workers", "--out"} <= cli_options.texsynth_batch_options(paths.ADDON)


@pytest.mark.parametrize("line", ["bash scripts/demo.sh", "bash scripts/test.sh"])
def test_readme_has_the_two_commands(line):
    lines = README.read_text(encoding="utf-8").splitlines()
    assert any(l.strip().startswith(line) for l in lines), f"README.md lacks the line `{line}`"
