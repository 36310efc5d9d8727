#!/usr/bin/env python3
"""Runs every command of the README and docs/guide/ as pasted (issue 43, "What must show").

Where `src/cli/docs_commands.rs` only *parses* each shown command with the binary's parser,
this runs them: each page in a fresh clone of the repository (`git clone` of HEAD, so nothing
uncommitted), with the data folder beside it as `../shared/data` (a link to --data), the
built `workbench` first on PATH. A page's commands run in its order in one clone, so a later
command sees the files an earlier one wrote; `export` and `cd` lines carry over.

What counts as a command is the guide's convention (docs/guide/README.md, "Commands in these
pages"), applied to shell lines rather than to `workbench` words: in a fenced block that is not
JSON or Python, every `$ ` line of a block with prompts, and otherwise every line (joined over
trailing backslashes) whose first word is a program on PATH, `workbench`, `export` or `cd`.
Lines with placeholders (FILE, N, `…`, `[--flag]`, `<x>`, `{}`) are synopses and not run.

Not run, and listed as such: builds and installs (`cargo …` but `cargo run --release --`,
which is run as the installed `workbench`; `pip`, `just`), cluster commands (`sbatch`,
`srun`, `parallel`, `ci/slurm.sh`) and anything matching --skip. A command still running after
--timeout seconds is stopped and listed as "timed out" (with the time its page states, when the
line or the sentence before its block names one).

    python3 ci/guide_commands.py --data ../shared/data [--bin target/release] \
        [--timeout 120] [--skip REGEX …] [--list] [PAGE.md …]

Exit status 1 if a command failed (non-zero exit), 0 otherwise; a report line per command.
"""

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
NOT_RUN = [
    (re.compile(r"^cargo (?!run --release -- )"), "a build, test or install"),
    (re.compile(r"^(pip|pip3|just|python3 -m venv|\. |source )"), "a build, install or venv"),
    (re.compile(r"\b(sbatch|srun|squeue|scancel|parallel|ci/slurm\.sh)\b"), "a cluster command"),
    (re.compile(r"^git (clone|pull|push|fetch)"), "needs the network"),
]
PLACEHOLDER = re.compile(r"(…|\.\.\.|\[--|<[a-z]|\{\}|\$\{?[A-Z_]+(?<!WORKBENCH_DATA)\b(?!=))")
CAPS_WORD = re.compile(r"(^|\s)[A-Z][A-Z0-9_]*(\.[a-z]+)?(\s|$)")
TIME = re.compile(r"(\d+(?:\.\d+)?\s*(?:min|minutes|s|h|hours?)\b[^.;)]*)")


def blocks(text):
    """Yields (line number, [lines], info) for each fenced block."""
    lines = text.splitlines()
    k = 0
    while k < len(lines):
        m = re.match(r"^\s*```(\w*)", lines[k])
        if not m:
            k += 1
            continue
        lang, start, body = m.group(1), k + 1, []
        k += 1
        while k < len(lines) and not lines[k].lstrip().startswith("```"):
            body.append(lines[k])
            k += 1
        before = " ".join(lines[max(0, start - 4) : start - 1])
        yield start + 1, body, lang, before
        k += 1


def is_command(line, bindir):
    words = line.split()
    while words and re.match(r"^[A-Z_]+=", words[0]):
        words = words[1:]
    if not words:
        return False
    first = words[0]
    if first in ("workbench", "export", "cd") or first.endswith("/workbench"):
        return True
    return shutil.which(first, path=f"{bindir}:{os.environ.get('PATH', '')}") is not None


def commands(page, bindir):
    text = page.read_text()
    for start, body, lang, before in blocks(text):
        if lang in ("json", "python", "toml", "text"):
            continue
        prompted = any(l.startswith("$ ") for l in body)
        k = 0
        while k < len(body):
            line, at = body[k], start + k
            if prompted and not line.startswith("$ "):
                k += 1
                continue
            line = line[2:] if line.startswith("$ ") else line
            while line.rstrip().endswith("\\") and k + 1 < len(body):
                k += 1
                line = line.rstrip()[:-1] + " " + body[k].strip()
            k += 1
            comment = ""
            if " #" in line:
                line, comment = line.split(" #", 1)
            line = line.strip()
            if not line or line.startswith("#") or not is_command(line, bindir):
                continue
            stated = TIME.search(comment) or TIME.search(before)
            yield at, line, stated.group(1).strip() if stated else ""


def run_page(page, args, report):
    clone = Path(tempfile.mkdtemp(prefix="guide-")) / "workbench"
    if not args.list:
        subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)], check=True)
        (clone.parent / "shared").mkdir()
        os.symlink(Path(args.data).resolve(), clone.parent / "shared" / "data")
    env = dict(os.environ, PATH=f"{Path(args.bin).resolve()}:{os.environ['PATH']}")
    env.pop("WORKBENCH_DATA", None)  # what the page says, not what this shell has
    carried = []  # export and cd lines, in order
    failed = 0
    name = page.relative_to(ROOT)
    for at, line, stated in commands(page, args.bin):
        where = f"{name}:{at}"
        shown = line
        if line.startswith("cargo run --release -- "):
            line = "workbench " + line[len("cargo run --release -- ") :]
        bare = re.sub(r"^(\s*[A-Z_]+=\S*\s+)+", "", line)  # without leading VAR=value
        why = next((w for r, w in NOT_RUN if r.search(bare)), None)
        if why is None and (PLACEHOLDER.search(line) or CAPS_WORD.search(line.split(" ", 1)[-1])):
            why = "a synopsis (placeholders)"
        if why is None and any(re.search(s, line) for s in args.skip):
            why = "skipped (--skip)" + (f"; stated: {stated}" if stated else "")
        if args.list or why:
            report(f"{'LIST' if args.list and not why else 'NOT RUN'} {where}: {shown}" + (f"  [{why}]" if why else ""))
            continue
        if line.startswith(("export ", "cd ")):
            carried.append(line)
        script = " && ".join(carried + ([] if line.startswith(("export ", "cd ")) else [line]))
        begun = time.monotonic()
        try:
            done = subprocess.run(
                ["nice", "-n", "10", "bash", "-c", script],
                cwd=clone,
                env=env,
                capture_output=True,
                text=True,
                timeout=args.timeout,
            )
        except subprocess.TimeoutExpired:
            report(f"TIMED OUT {where}: {shown}  [> {args.timeout} s; stated: {stated or 'no time stated'}]")
            continue
        took = time.monotonic() - begun
        if done.returncode == 0:
            report(f"ok {where} ({took:.1f} s): {shown}")
        else:
            failed += 1
            last = (done.stderr.strip() or done.stdout.strip()).splitlines()[-1:] or [""]
            report(f"FAILED {where} (exit {done.returncode}, {took:.1f} s): {shown}\n    {last[0]}")
    if args.list or not args.keep:
        shutil.rmtree(clone.parent, ignore_errors=True)
    return failed


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("pages", nargs="*", help="pages (default: README.md and docs/guide/*.md)")
    p.add_argument("--data", required=True, help="the data folder, linked as ../shared/data")
    p.add_argument("--bin", default=str(ROOT / "target/release"), help="the folder of the built workbench")
    p.add_argument("--timeout", type=float, default=120, help="seconds a command may take")
    p.add_argument("--skip", action="append", default=[], help="a regex: matching commands are not run")
    p.add_argument("--list", action="store_true", help="list the commands, run nothing")
    p.add_argument("--keep", action="store_true", help="keep the clones")
    args = p.parse_args()
    pages = [Path(x).resolve() for x in args.pages] or [ROOT / "README.md"] + sorted((ROOT / "docs/guide").glob("*.md"))
    failed = 0
    for page in pages:
        failed += run_page(page, args, lambda s: print(s, flush=True))
    print(f"{failed} failed", flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
