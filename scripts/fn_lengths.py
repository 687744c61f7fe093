#!/usr/bin/env python3
"""The longest functions of the workspace's Rust sources (tests, fuzz targets and build
output left out), and how many run over 100 and 60 lines.

Usage: python3 scripts/fn_lengths.py [N]   (the N longest; default 10)

A reader of braces, not a parser: a function runs from its `fn` line to the brace that
closes its body, strings, characters and comments aside.
"""

import os
import re
import sys

FN = re.compile(r"^\s*(pub(\([\w:]+\))?\s+)?((const|unsafe|async|extern\s+\"C\")\s+)*fn\s+(\w+)")


def functions(path):
    lines = open(path, encoding="utf-8", errors="replace").read().split("\n")
    end = len(lines)
    for i, line in enumerate(lines):
        if re.match(r"\s*#\[cfg\(test\)\]", line) and i + 1 < len(lines) and re.match(r"\s*(pub\s+)?mod\s+\w+", lines[i + 1]):
            end = i
            break
    i = 0
    while i < end:
        m = FN.match(lines[i])
        if not m:
            i += 1
            continue
        depth, opened, j = 0, False, i
        while j < len(lines):
            s = re.sub(r"//.*", "", lines[j])
            s = re.sub(r'"(\\.|[^"\\])*"', '""', s)
            s = re.sub(r"'(\\.|[^'\\])'", "''", s)
            if not opened and ";" in s and "{" not in s:
                break
            depth += s.count("{") - s.count("}")
            opened = opened or "{" in s
            if opened and depth <= 0:
                yield (j - i + 1, i + 1, m.group(5))
                break
            j += 1
        i += 1


def main():
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    rows = []
    for d, dirs, names in os.walk(root):
        dirs[:] = [x for x in dirs if x not in ("target", ".git", "fuzz", "tests")]
        for n in names:
            if n.endswith(".rs") and n != "tests.rs":
                p = os.path.join(d, n)
                rows += [(k, os.path.relpath(p, root), line, name) for k, line, name in functions(p)]
    rows.sort(reverse=True)
    for k, p, line, name in rows[: int(sys.argv[1]) if len(sys.argv) > 1 else 10]:
        print(f"{k:4d} {p}:{line} {name}")
    print(f"functions: {len(rows)}, over 100 lines: {sum(r[0] > 100 for r in rows)}, over 60: {sum(r[0] > 60 for r in rows)}")


if __name__ == "__main__":
    main()
