#!/usr/bin/env python3
"""Checks the relative links of the Markdown docs (README.md, docs/, docs/notes/): every linked
file exists and every #anchor names a heading of its file (GitHub's slugs). Prints each broken
link with its file and line; exits 1 if any. Outside links (http, mailto) are not followed."""
import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
HEADING = re.compile(r"^(#{1,6})\s+(.*?)\s*#*\s*$")


def prose(path):
    """The file's lines with fenced code blanked (links in code are examples)."""
    fenced = False
    for line in path.read_text(encoding="utf-8").split("\n"):
        if line.lstrip().startswith("```"):
            fenced = not fenced
            yield ""
        else:
            yield "" if fenced else line


def slug(heading):
    text = re.sub(r"[`*]|\[([^\]]*)\]\([^)]*\)", lambda m: m.group(1) or "", heading)
    text = re.sub(r"[^\w\- ]", "", text.strip().lower())
    return text.replace(" ", "-")


_anchors = {}


def anchors(path):
    if path not in _anchors:
        found, count = set(), {}
        for line in prose(path):
            m = HEADING.match(line)
            if not m:
                continue
            s = slug(m.group(2))
            n = count.get(s, -1) + 1
            count[s] = n
            found.add(s if n == 0 else f"{s}-{n}")
        _anchors[path] = found
    return _anchors[path]


def main():
    files = [ROOT / "README.md"] + sorted((ROOT / "docs").glob("*.md")) + sorted(
        (ROOT / "docs" / "notes").glob("*.md"))
    broken = checked = 0
    for f in files:
        for number, line in enumerate(prose(f), 1):
            for target in LINK.findall(line):
                if re.match(r"^[a-z]+:", target):
                    continue
                checked += 1
                name, _, anchor = target.partition("#")
                dest = (f.parent / name).resolve() if name else f
                problem = None
                if not dest.exists():
                    problem = "no such file"
                elif anchor and dest.suffix == ".md" and anchor not in anchors(dest):
                    problem = "no such heading"
                if problem:
                    broken += 1
                    print(f"{f.relative_to(ROOT)}:{number}: {target}: {problem}")
    print(f"{checked} links checked, {broken} broken")
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main())
