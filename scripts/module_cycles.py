#!/usr/bin/env python3
"""Lists import cycles between the top-level modules of a crate's `src/` (a module's
`crate::other` references, doc links and tests included). Exit 1 if there is one.

Usage: scripts/module_cycles.py CRATE_SRC_DIR...
"""
import os
import re
import sys


def modules(src):
    graph = {}
    for root, _, files in os.walk(src):
        for f in files:
            if not f.endswith(".rs"):
                continue
            path = os.path.join(root, f)
            rel = os.path.relpath(path, src)
            top = rel.split(os.sep)[0]
            top = top[:-3] if top.endswith(".rs") else top
            if top in ("lib", "main"):
                continue
            text = open(path, encoding="utf-8").read()
            deps = set(re.findall(r"\bcrate::([a-z_][a-z0-9_]*)", text))
            deps |= set(re.findall(r"\bsuper::super::([a-z_][a-z0-9_]*)", text))
            graph.setdefault(top, set()).update(d for d in deps if d != top)
    return graph


def cycles(graph):
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in graph:
                continue
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
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


bad = False
for src in sys.argv[1:]:
    for comp in cycles(modules(src)):
        bad = True
        print(f"{src}: cycle between {', '.join(comp)}")
sys.exit(1 if bad else 0)
