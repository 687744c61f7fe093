#!/usr/bin/env python3
"""The workspace's import rules, checked from the source text (CI runs it).

1. No import loop between the files of any crate: a file depends on another when it names a
   path into it (`use crate::a::b`, `crate::a::f()`, `super::x`, braces expanded); a module and
   its own descendants are one room, so their paths to each other do not count.
2. The bake is in layers: `bake/src/lib.rs` declares its top-level modules bottom-up, and every
   module names only modules declared before it (its own descendants aside).
3. ARCHITECTURE.md's stage table for the bake lists those modules in the same order.

Comments, doc comments and `#[cfg(test)] mod` blocks are left out: tests may reach anywhere.
A reader of Rust text, not a compiler: a path built by a macro is not seen.

Usage: python3 scripts/layers.py [--verbose]; exit status 1 on any breach.
"""

import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
IDENT = r"[A-Za-z_][A-Za-z0-9_]*"
LAYERED = "bake"


def strip(text):
    """The text without comments, strings and `#[cfg(test)] mod … { … }` blocks."""
    text = re.sub(r'"(\\.|[^"\\])*"', '""', text)
    out, skip, depth = [], False, 0
    lines = text.split("\n")
    i = 0
    while i < len(lines):
        line = re.sub(r"//.*", "", lines[i])
        if not skip and re.match(r"\s*#\[cfg\(test\)\]", line):
            nxt = lines[i + 1] if i + 1 < len(lines) else ""
            if re.match(r"\s*(pub(\([\w:]+\))?\s+)?mod\s+\w+\s*\{", nxt):
                skip, depth = True, 0
                i += 1
                continue
            if re.match(r"\s*(pub(\([\w:]+\))?\s+)?mod\s+\w+\s*;", nxt):
                i += 2
                continue
        if skip:
            depth += line.count("{") - line.count("}")
            if depth <= 0 and "}" in line:
                skip = False
            i += 1
            continue
        out.append(line)
        i += 1
    return "\n".join(out)


def expand(tree):
    """`a::{b, c::{d, e}}` -> ['a::b', 'a::c::d', 'a::c::e']"""
    tree = re.sub(r"\s+", "", tree)
    m = re.match(r"^(.*?)\{(.*)\}$", tree)
    if not m:
        return [tree]
    prefix, inner = m.group(1), m.group(2)
    parts, depth, cur = [], 0, ""
    for ch in inner:
        if ch == "{":
            depth += 1
        elif ch == "}":
            depth -= 1
        if ch == "," and depth == 0:
            parts.append(cur)
            cur = ""
        else:
            cur += ch
    if cur:
        parts.append(cur)
    return [q for p in parts if p for q in expand(prefix + p)]


def module_of(src, path):
    rel = os.path.relpath(path, src)[:-3].split(os.sep)
    if rel[-1] in ("lib", "main", "mod"):
        rel = rel[:-1]
    return tuple(rel)


def paths_in(text, here):
    """Absolute module paths (tuples) that `text`, the file of module `here`, names."""
    found = []
    for m in re.finditer(r"\buse\s+([^;]+);", text):
        found += expand(m.group(1))
    found += re.findall(r"\b((?:crate|super)(?:::" + IDENT + r")+)", text)
    out = []
    for p in found:
        p = re.sub(r"\bas\s*" + IDENT + "$", "", p.replace(" ", ""))
        segs = [s for s in p.split("::") if s]
        if not segs or segs[0] not in ("crate", "super", "self"):
            continue
        if segs[0] == "crate":
            base, rest = [], segs[1:]
        else:
            base = list(here)
            rest = segs
            while rest and rest[0] in ("super", "self"):
                if rest[0] == "super":
                    base = base[:-1]
                rest = rest[1:]
        out.append(tuple(base + rest))
    return out


def crate_files(crate):
    src = os.path.join(crate, "src")
    files = {}
    for root, dirs, names in os.walk(src):
        dirs[:] = [d for d in dirs if d != "tests"]
        for n in names:
            if n.endswith(".rs") and n != "tests.rs":
                p = os.path.join(root, n)
                files[module_of(src, p)] = p
    return files


def loops(crate, verbose):
    files = crate_files(crate)
    edges = {m: {} for m in files}
    for m, p in files.items():
        for target in paths_in(strip(open(p, encoding="utf-8").read()), m):
            # The longest prefix that is a file.
            t = next((target[:k] for k in range(len(target), -1, -1) if target[:k] in files), None)
            if t is None or t == m:
                continue
            # A module and its descendants are one room.
            if t[: len(m)] == m or m[: len(t)] == t:
                continue
            name = target[len(t)] if len(target) > len(t) else "(module)"
            edges[m].setdefault(t, set()).add(name)
    # Tarjan's strongly connected components.
    index, low, stack, on, comps, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in edges[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                comps.append(comp)

    sys.setrecursionlimit(10000)
    for v in sorted(edges):
        if v not in index:
            visit(v)
    problems = []
    for comp in comps:
        names = sorted(os.path.relpath(files[m], ROOT) for m in comp)
        problems.append(f"import loop in {crate}: " + ", ".join(names))
        if verbose:
            for a in comp:
                for b, why in edges[a].items():
                    if b in comp:
                        problems.append(
                            f"  {os.path.relpath(files[a], ROOT)} -> "
                            f"{os.path.relpath(files[b], ROOT)}: {', '.join(sorted(why))}"
                        )
    return problems


def declared_layers(crate):
    """The top-level modules of `crate`'s lib.rs in declaration order: its `mod`s, and the
    modules of other crates it re-exports (`pub use other_crate::m;`, `pub use c as m;`)."""
    text = strip(open(os.path.join(crate, "src", "lib.rs"), encoding="utf-8").read())
    order = []
    for m in re.finditer(r"^\s*(?:pub(?:\([\w:]+\))?\s+)?(?:mod\s+(" + IDENT + r")|use\s+([\w:]+)(?:\s+as\s+(" + IDENT + r"))?\s*;)", text, re.M):
        if m.group(1):
            order.append(m.group(1))
            continue
        path = m.group(2).split("::")
        if path[0] in order or path[0] in ("crate", "self", "super"):
            continue  # an item of a module of its own, not a layer
        order.append(m.group(3) or path[-1])
    return order


def layering(crate, verbose):
    order = declared_layers(crate)
    rank = {m: i for i, m in enumerate(order)}
    problems = []
    for mod, path in sorted(crate_files(crate).items()):
        if not mod or mod[0] not in rank:
            continue
        top = mod[0]
        seen = {}
        for target in paths_in(strip(open(path, encoding="utf-8").read()), mod):
            if target and target[0] in rank and rank[target[0]] > rank[top]:
                seen.setdefault(target[0], set()).add("::".join(target[1:]) or "(module)")
        for later, names in sorted(seen.items()):
            line = f"{os.path.relpath(path, ROOT)} (layer {top}) names {later}, declared above it"
            if verbose:
                line += ": " + ", ".join(sorted(names))
            problems.append(line)
    return problems, order


def architecture_table(order):
    """The bake's stage table in ARCHITECTURE.md against lib.rs's order."""
    text = open(os.path.join(ROOT, "ARCHITECTURE.md"), encoding="utf-8").read()
    m = re.search(r"<!-- bake layers -->(.*?)<!-- /bake layers -->", text, re.S)
    if not m:
        return ["ARCHITECTURE.md: no bake layer table (between <!-- bake layers --> markers)"]
    listed = re.findall(r"^\|[^|]*\|\s*`([a-z_]+)/?`", m.group(1), re.M)
    if listed != order:
        return [
            "ARCHITECTURE.md's bake layer table does not match bake/src/lib.rs:\n"
            f"  table:  {' '.join(listed)}\n  lib.rs: {' '.join(order)}"
        ]
    return []


def main():
    verbose = "--verbose" in sys.argv
    os.chdir(ROOT)
    crates = sorted(
        d
        for d, _, names in os.walk(".")
        if "Cargo.toml" in names
        and os.path.isdir(os.path.join(d, "src"))
        and not any(p in d for p in ("/target", "/.git", "/fuzz"))
    )
    problems = []
    for crate in crates:
        problems += loops(os.path.normpath(crate), verbose)
    layer_problems, order = layering(LAYERED, verbose)
    problems += layer_problems
    problems += architecture_table(order)
    for p in problems:
        print(p)
    if problems:
        return 1
    print(f"no import loop in {len(crates)} crates; the bake's {len(order)} layers import downwards only")
    return 0


if __name__ == "__main__":
    sys.exit(main())
