#!/usr/bin/env python3
"""Finds circles of module files that import each other inside a Rust crate. Exit 1 if any.

Usage:
    scripts/module_cycles.py CRATE_DIR...   # a crate directory (with Cargo.toml) or a `src/` dir
    scripts/module_cycles.py --self-test     # the fixtures in scripts/module_cycles_fixtures/

Nodes. Every module FILE is a node (`src/a.rs`, `src/a/mod.rs`, `src/a/b.rs`, ...); submodules are
never folded into their parent. The module tree is found by following `mod x;` declarations
(`#[path]` honoured) from each crate root: `src/lib.rs`, `src/main.rs`, `src/bin/*.rs`, and each
file directly in `tests/`, `benches/` and `examples/` (each of those is a crate of its own).

Edges. File A depends on file B when A's code (tests included; comments, doc comments and string
literals excluded) names a path into B:
  * `crate::a::b::Item`, `$crate::...`, `super::...`, `super::super::...`, `self::...`, anywhere:
    in `use` declarations (groups such as `use crate::{a, b::{c, d}}` are expanded), in
    expressions, types, attributes and macros. `super`/`self` inside an inline `mod tests { }`
    are resolved from that inline module, so `use super::*` in a file's own tests is no edge.
  * a bare path `child::Item` whose first segment is a module the file declares (`mod child;`),
    or a name the file brought in with `use` (`use crate::a; a::b::f()`).
  A path resolves to the deepest module file it reaches (`crate::a::b::Item` -> `a/b.rs` if that
  file exists, else `a.rs`). If the file reached only re-exports the item (`pub use x::Item;`, or
  a `pub use x::*` while not defining it), the edge goes to the file defining it instead, so
  `crate::Item` re-exported by `lib.rs` from `a.rs` is an edge to `a.rs`, not to `lib.rs`.
Not edges:
  * `mod child;` declarations (declaring a child is not using it);
  * a re-export of a descendant (`pub use child::Item;`, `pub use self::child::*`, any `pub(..)`
    visibility) when the file does not otherwise use the re-exported name: a facade passes the
    child's items through without depending on them. If the re-exported name is also used in the
    file's own code, the re-export counts as a use and is an edge;
  * paths to other crates (`std::`, `atrium_robots::`) and `pub(in crate::x)` visibilities.
So a parent that declares a child and re-exports its items, while the child uses `super::Thing`
defined in the parent, is one way (child -> parent). A parent whose code calls the child
(`child::f()`, `use self::child::X` then `X`) while the child uses `super::Thing` is a circle.

Circles are the strongly connected components of this graph with more than one file; each is
printed with the lines that make its edges.
"""
import os
import re
import sys

from rust_source import strip

IDENT = r"[A-Za-z_][A-Za-z0-9_]*"
KEYWORDS = {"crate", "super", "self", "$crate"}


def inline_mods(code):
    """(start, end, name) of every inline `mod name { ... }`."""
    spans = []
    for m in re.finditer(r"\bmod\s+(" + IDENT + r")\s*\{", code):
        depth, j = 1, m.end()
        while j < len(code) and depth:
            if code[j] == "{":
                depth += 1
            elif code[j] == "}":
                depth -= 1
            j += 1
        spans.append((m.start(), j, m.group(1)))
    return spans


def context_at(spans, pos):
    return [name for (a, b, name) in spans if a <= pos < b]


def split_top(s):
    parts, depth, cur = [], 0, ""
    for ch in s:
        if ch == "{":
            depth += 1
        elif ch == "}":
            depth -= 1
        if ch == "," and depth == 0:
            parts.append(cur)
            cur = ""
        else:
            cur += ch
    parts.append(cur)
    return [p.strip() for p in parts if p.strip()]


def expand_use(tree, prefix=()):
    """`crate::{a, b::{c as d, *}}` -> [(['crate','a'], 'a'), (['crate','b','c'], 'd'), (['crate','b','*'], None)]."""
    tree = re.sub(r"\s+", " ", tree.strip())
    if tree.startswith("::"):
        tree = tree[2:]
    brace = tree.find("{")
    if brace >= 0:
        head = tree[:brace].strip().rstrip(":").strip()
        head_segs = [s.strip() for s in head.split("::") if s.strip()]
        inner = tree[brace + 1:tree.rfind("}")]
        out = []
        for part in split_top(inner):
            out += expand_use(part, prefix + tuple(head_segs))
        return out
    alias = None
    m = re.match(r"(.*?)\s+as\s+(" + IDENT + r")$", tree)
    if m:
        tree, alias = m.group(1), m.group(2)
    segs = list(prefix) + [s.strip() for s in tree.split("::") if s.strip()]
    if segs and segs[-1] == "self":
        segs = segs[:-1]
    if not segs:
        return []
    if segs[-1] == "*":
        return [(segs, None)]
    return [(segs, alias or (None if alias == "_" else segs[-1]))]


class File:
    def __init__(self, path, modpath, is_dir_owner):
        self.path = path
        self.modpath = tuple(modpath)
        self.is_dir_owner = is_dir_owner  # lib.rs, main.rs, mod.rs: children live beside it
        raw = open(path, encoding="utf-8").read()
        self.code = strip(raw)
        self.spans = inline_mods(self.code)
        self.children = {}  # name -> (path attr or None, inline context)
        for m in re.finditer(r"((?:#\[[^\]]*\]\s*)*)(?:pub(?:\([^)]*\))?\s+)?mod\s+(" + IDENT + r")\s*;", self.code):
            pm = re.search(r"#\[path\s*=\s*\"([^\"]+)\"\]", raw[m.start():m.end()])
            self.children[m.group(2)] = (pm.group(1) if pm else None, context_at(self.spans, m.start()))
        self.uses = []  # (segments, binding, is_pub, line, ctx)
        self.use_ranges = []
        for m in re.finditer(r"(?<![\w:])(pub(?:\s*\([^)]*\))?\s+)?use\s+([^;]*);", self.code):
            ctx = context_at(self.spans, m.start())
            line = self.code.count("\n", 0, m.start()) + 1
            for segs, binding in expand_use(m.group(2)):
                self.uses.append((segs, binding, bool(m.group(1)), line, ctx))
            self.use_ranges.append((m.start(), m.end()))
        self.defines = set(re.findall(
            r"\b(?:fn|struct|enum|trait|type|const|static|union|mod|macro_rules!)\s+(" + IDENT + r")", self.code))

    def line_of(self, pos):
        return self.code.count("\n", 0, pos) + 1


class Crate:
    def __init__(self, roots):
        self.files = {}  # path -> File
        self.by_mod = {}  # (root, modpath) -> File
        for root in roots:
            self.load(root, root, (), True)

    def load(self, root, path, modpath, dir_owner):
        path = os.path.normpath(path)
        if path in self.files or not os.path.exists(path):
            return
        f = File(path, modpath, dir_owner)
        f.root = root
        self.files[path] = f
        self.by_mod[(root, f.modpath)] = f
        here = os.path.dirname(path)
        own = here if dir_owner else os.path.join(here, os.path.splitext(os.path.basename(path))[0])
        for name, (attr, ctx) in f.children.items():
            if attr:
                child = os.path.join(here if not ctx else os.path.join(own, *ctx), attr)
                self.load(root, child, modpath + tuple(ctx) + (name,), os.path.basename(child) == "mod.rs")
                continue
            base = os.path.join(own, *ctx)
            flat, nested = os.path.join(base, name + ".rs"), os.path.join(base, name, "mod.rs")
            if os.path.exists(flat):
                self.load(root, flat, modpath + tuple(ctx) + (name,), False)
            elif os.path.exists(nested):
                self.load(root, nested, modpath + tuple(ctx) + (name,), True)

    def absolute(self, f, segs, ctx):
        """Absolute module path (tuple) of a path written in file f inside inline modules ctx."""
        segs = list(segs)
        here = list(f.modpath) + list(ctx)
        if segs[0] in ("crate", "$crate"):
            return tuple(segs[1:])
        if segs[0] == "self":
            return tuple(here + segs[1:])
        if segs[0] == "super":
            while segs and segs[0] == "super":
                here = here[:-1]
                segs = segs[1:]
            if segs and segs[0] == "self":
                segs = segs[1:]
            return tuple(here + segs)
        # bare path: a declared child module, or a name brought in by `use`
        if segs[0] in f.children:
            return tuple(list(f.modpath) + list(f.children[segs[0]][1]) + segs)
        for usegs, binding, _, _, uctx in f.uses:
            if binding == segs[0] and usegs[0] in KEYWORDS | set(f.children):
                if usegs[0] in KEYWORDS:
                    return self.absolute(f, usegs, uctx) + tuple(segs[1:])
                return tuple(list(f.modpath) + usegs) + tuple(segs[1:])
        return None

    def resolve(self, root, abspath, seen=None):
        """The file defining what abspath names (following re-exports)."""
        seen = seen or set()
        for k in range(len(abspath), -1, -1):
            f = self.by_mod.get((root, tuple(abspath[:k])))
            if f is None:
                continue
            rest = abspath[k:]
            if not rest or (f.path, rest[0]) in seen:
                return f
            seen.add((f.path, rest[0]))
            name = rest[0]
            for segs, binding, is_pub, _, ctx in f.uses:
                if is_pub and binding == name:
                    target = self.absolute(f, segs, ctx)
                    if target is not None:
                        return self.resolve(root, target + tuple(rest[1:]), seen)
            if name not in f.defines:
                for segs, binding, is_pub, _, ctx in f.uses:
                    if is_pub and binding is None:
                        target = self.absolute(f, segs[:-1], ctx)
                        if target is None:
                            continue
                        g = self.resolve(root, target + tuple(rest), seen)
                        if g is not f and name in g.defines:
                            return g
            return f
        return None

    def edges(self):
        """{file: {file: [evidence line numbers]}}"""
        out = {p: {} for p in self.files}
        for f in self.files.values():
            def add(abspath, line):
                g = self.resolve(f.root, abspath) if abspath is not None else None
                if g is not None and g is not f:
                    out[f.path].setdefault(g.path, []).append(line)

            for segs, binding, is_pub, line, ctx in f.uses:
                absp = self.absolute(f, segs if segs[-1] != "*" else segs[:-1], ctx)
                if absp is None:
                    continue
                if is_pub and absp[:len(f.modpath)] == f.modpath and len(absp) > len(f.modpath):
                    # re-export of a descendant: an edge only if the file uses the name itself
                    if binding is None or not self.used_outside_uses(f, binding):
                        continue
                add(absp, line)
            pattern = r"(?<![\w:$])(\$crate|crate|self|super|" + "|".join(
                [re.escape(c) for c in f.children] + [re.escape(b) for (s, b, _, _, _) in f.uses if b]
                or ["(?!)"]) + r")((?:\s*::\s*(?:" + IDENT + r"))+)"
            for m in re.finditer(pattern, f.code):
                if any(a <= m.start() < b for a, b in f.use_ranges):
                    continue
                before = f.code[max(0, m.start() - 12):m.start()]
                if re.search(r"pub\s*\(\s*in\s+$", before):
                    continue
                segs = [m.group(1)] + [s.strip() for s in m.group(2).split("::") if s.strip()]
                ctx = context_at(f.spans, m.start())
                add(self.absolute(f, segs, ctx), f.line_of(m.start()))
        return out

    @staticmethod
    def used_outside_uses(f, name):
        for m in re.finditer(r"(?<![\w:])" + re.escape(name) + r"\b", f.code):
            if any(a <= m.start() < b for a, b in f.use_ranges):
                continue
            if re.search(r"\bmod\s+$", f.code[max(0, m.start() - 8):m.start()]):
                continue  # the child's own `mod name;` declaration
            return True
        return False


def roots_of(crate_dir):
    if os.path.basename(os.path.normpath(crate_dir)) == "src" and not os.path.exists(os.path.join(crate_dir, "Cargo.toml")):
        src, crate_dir = crate_dir, os.path.dirname(os.path.normpath(crate_dir))
    else:
        src = os.path.join(crate_dir, "src")
    roots = [os.path.join(src, r) for r in ("lib.rs", "main.rs") if os.path.exists(os.path.join(src, r))]
    for d in (os.path.join(src, "bin"), os.path.join(crate_dir, "tests"),
              os.path.join(crate_dir, "benches"), os.path.join(crate_dir, "examples")):
        if os.path.isdir(d):
            roots += sorted(os.path.join(d, f) for f in os.listdir(d) if f.endswith(".rs"))
            roots += sorted(os.path.join(d, f, "main.rs") for f in os.listdir(d)
                            if os.path.exists(os.path.join(d, f, "main.rs")))
    return roots


def cycles(graph):
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]
    sys.setrecursionlimit(10000)

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(graph.get(v, ())):
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


def check(crate_dir, quiet=False):
    roots = [r for r in roots_of(crate_dir)]
    crate = Crate(roots)
    graph = crate.edges()
    found = cycles(graph)
    if not quiet:
        for comp in found:
            print(f"{crate_dir}: circle between {', '.join(os.path.relpath(p, crate_dir) for p in comp)}")
            for a in comp:
                for b in comp:
                    if b in graph[a]:
                        lines = ",".join(str(x) for x in sorted(set(graph[a][b]))[:6])
                        print(f"    {os.path.relpath(a, crate_dir)} -> {os.path.relpath(b, crate_dir)} (lines {lines})")
    return found


def self_test():
    here = os.path.join(os.path.dirname(os.path.abspath(__file__)), "module_cycles_fixtures")
    expect_fail = {"circle", "super_circle", "parent_child", "group_circle", "reexport_circle"}
    expect_pass = {"one_way"}
    ok = True
    for name in sorted(expect_fail | expect_pass):
        found = check(os.path.join(here, name), quiet=True)
        want = name in expect_fail
        good = bool(found) == want
        ok &= good
        print(f"self-test {name}: {'circle found' if found else 'no circle'} "
              f"({'ok' if good else 'WRONG, expected ' + ('a circle' if want else 'none')})")
    return ok


def main(argv):
    if argv[1:] == ["--self-test"]:
        return 0 if self_test() else 1
    if len(argv) < 2:
        print(__doc__)
        return 2
    bad = False
    for d in argv[1:]:
        if check(d):
            bad = True
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
