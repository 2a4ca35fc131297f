#!/usr/bin/env python3
"""The layering check: the library's top-level modules (src/<name>/ or src/<name>.rs) must
not import each other in a cycle. Reads every `crate::<module>` path in code (comments
and `#[cfg(test)]` modules left out: tests may use any layer), prints the layers from
the bottom up, each with the modules it uses, and exits 1 naming a cycle's edges and
the lines that make them."""
import collections
import os
import re
import sys

SRC = sys.argv[1] if len(sys.argv) > 1 else "src"
# The built-in backends (backends/, mounted as `phyxel::backends`) name the crate
# `phyxel::`, as an outside crate would.
BACKENDS = os.path.join(os.path.dirname(os.path.abspath(SRC)), "backends")
# The binary's modules (src/main.rs, src/cli/) are another crate: its `crate::` is not ours.
SKIP = {"lib", "main", "cli"}

uses = collections.defaultdict(set)
where = collections.defaultdict(list)
sources = [(f, n, SRC) for f, _, ns in os.walk(SRC) for n in ns]
sources += [(f, n, BACKENDS) for f, _, ns in os.walk(BACKENDS) for n in ns]
for folder, name, base in sources:
        if not name.endswith(".rs") or name == "tests.rs":
            continue
        path = os.path.join(folder, name)
        rel = os.path.relpath(path, base)
        top = rel.split(os.sep)[0].removesuffix(".rs")
        if base == BACKENDS:
            top, rel = "backends", os.path.join("..", "backends", rel)
        elif top in SKIP:
            continue
        text = open(path, encoding="utf-8").read()
        # A unit-test module closes the file.
        text = re.split(r"#\[cfg\(test\)\]\s*mod \w+ \{", text)[0]
        text = re.sub(r"//[^\n]*", "", text)
        if base == BACKENDS:
            text = text.replace("phyxel::", "crate::")
        lines = text.split("\n")
        for number, line in enumerate(lines, 1):
            for m in re.finditer(r"crate::(\w+)", line):
                target = m.group(1)
                if target != top:
                    uses[top].add(target)
                    where[(top, target)].append(f"src/{rel}:{number}")
        # `use crate::{a::.., b::..}` over several lines.
        for m in re.finditer(r"crate::\{([^;]*)\}", text, re.S):
            for target in re.findall(r"(?:^|[,{])\s*(\w+)", m.group(1)):
                if target != top and target not in ("self",):
                    line = text[: m.start()].count("\n") + 1
                    uses[top].add(target)
                    where[(top, target)].append(f"src/{rel}:{line}")

modules = sorted(set(uses) | {t for ts in uses.values() for t in ts})
modules = [
    m
    for m in modules
    if m == "backends" or any(os.path.exists(os.path.join(SRC, m + e)) for e in ("", ".rs"))
]
uses = {m: {t for t in uses.get(m, ()) if t in modules} for m in modules}

# Layers from the bottom: each module after everything it uses.
order, left = [], set(modules)
while left:
    ready = sorted(m for m in left if uses[m] <= set(order))
    if not ready:
        break
    order.extend(ready)
    left -= set(ready)
for m in order:
    print(f"{m:10} uses {', '.join(sorted(uses[m], key=order.index)) or '-'}")
if left:
    print("\nimport cycle among: " + ", ".join(sorted(left)), file=sys.stderr)
    for a in sorted(left):
        for b in sorted(uses[a] & left):
            print(f"  {a} -> {b}: {', '.join(where[(a, b)][:4])}", file=sys.stderr)
    sys.exit(1)
