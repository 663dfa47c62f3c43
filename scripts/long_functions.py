#!/usr/bin/env python3
"""Lists non-test Rust functions longer than a limit and non-test functions returning
`Result<_, String>`, per crate. Exit 1 if any is found (so it can serve as a CI check).

Usage:
    scripts/long_functions.py [--max-lines N] [--quiet] [CRATE_DIR...]
    # default: every workspace member listed in ./Cargo.toml; N defaults to 150

Length. A function is counted from the line of its `fn` keyword to the line of its closing brace,
both included (attributes and doc comments above it are not counted; closures and nested items in
its body are). Nested `fn` items are measured on their own as well.

Test code is skipped: files under a crate's `tests/`, `benches/`, `examples/` and `fuzz_targets/`
directories, `#[cfg(test)]` items (typically `mod tests { ... }`) and `#[test]` functions.

String errors: the signature's return type, after `->`, is `Result<T, String>` (any `T`,
`std::result::Result` too). Comments and string literals are blanked first, so a `fn` inside a
doc example or a string is never counted.
"""
import os
import re
import sys

from rust_source import strip

IDENT = r"[A-Za-z_][A-Za-z0-9_]*"
TEST_DIRS = {"tests", "benches", "examples", "fuzz_targets", "target"}


def matching(code, open_at, open_ch, close_ch):
    """Index of the bracket closing the one at `open_at`."""
    depth = 0
    for k in range(open_at, len(code)):
        ch = code[k]
        if ch == open_ch:
            depth += 1
        elif ch == close_ch:
            depth -= 1
            if depth == 0:
                return k
    return len(code) - 1


def test_spans(code):
    """Spans (start, end) of items marked `#[cfg(test)]` or `#[test]`."""
    spans = []
    for m in re.finditer(r"#\s*\[\s*(?:cfg\s*\(\s*test\s*\)|test)\s*\]", code):
        k = m.end()
        # Skip further attributes, then find the item's body (or its `;`).
        while True:
            rest = re.match(r"\s*#\s*\[", code[k:])
            if not rest:
                break
            k = matching(code, k + rest.end() - 1, "[", "]") + 1
        brace, semi = code.find("{", k), code.find(";", k)
        if brace < 0 or (0 <= semi < brace):
            spans.append((m.start(), semi if semi >= 0 else len(code)))
        else:
            spans.append((m.start(), matching(code, brace, "{", "}")))
    return spans


def functions(code):
    """Yields (name, start offset, end offset, return type text) for each fn with a body."""
    for m in re.finditer(r"\bfn\s+(" + IDENT + r")", code):
        k = m.end()
        if code[k:k + 1] == "<":
            # Generic parameters; `->` inside them (Fn bounds) must not unbalance the count.
            depth = 0
            while k < len(code):
                if code[k] == "<":
                    depth += 1
                elif code[k] == ">" and code[k - 1] != "-":
                    depth -= 1
                    if depth == 0:
                        k += 1
                        break
                k += 1
        paren = code.find("(", k)
        if paren < 0:
            continue
        close = matching(code, paren, "(", ")")
        # The body is the first `{` at bracket depth 0 after the parameters (`where` clauses and
        # return types hold no braces); a `;` first means a declaration without a body.
        depth, k, body = 0, close + 1, None
        while k < len(code):
            ch = code[k]
            if ch in "([<" and not (ch == "<" and code[k - 1] == "-"):
                depth += 1
            elif ch in ")]>" and not (ch == ">" and code[k - 1] == "-"):
                depth -= 1
            elif ch == ";" and depth <= 0:
                break
            elif ch == "{" and depth <= 0:
                body = k
                break
            k += 1
        if body is None:
            continue
        signature = code[close + 1:body]
        arrow = signature.find("->")
        ret = signature[arrow + 2:] if arrow >= 0 else ""
        ret = re.split(r"\bwhere\b", ret)[0]
        yield m.group(1), m.start(), matching(code, body, "{", "}"), " ".join(ret.split())


def string_error(ret):
    m = re.match(r"^(?:std\s*::\s*result\s*::\s*|core\s*::\s*result\s*::\s*)?Result\s*<(.*)>$", ret)
    if not m:
        return False
    inner, depth, last_comma = m.group(1), 0, -1
    for k, ch in enumerate(inner):
        if ch in "<([":
            depth += 1
        elif ch in ">)]":
            depth -= 1
        elif ch == "," and depth == 0:
            last_comma = k
    return last_comma >= 0 and inner[last_comma + 1:].strip() in ("String", "std::string::String")


def rust_files(crate):
    for root, dirs, files in os.walk(crate):
        rel = os.path.relpath(root, crate)
        parts = [] if rel == "." else rel.split(os.sep)
        if any(p in TEST_DIRS for p in parts):
            dirs[:] = []
            continue
        dirs[:] = sorted(d for d in dirs if d not in TEST_DIRS and not d.startswith("."))
        for f in sorted(files):
            if f.endswith(".rs"):
                yield os.path.join(root, f)


def scan(path, max_lines):
    with open(path, encoding="utf-8") as fh:
        code = strip(fh.read())
    spans = test_spans(code)
    long, stringly = [], []
    for name, start, end, ret in functions(code):
        if any(a <= start <= b for a, b in spans):
            continue
        line = code.count("\n", 0, start) + 1
        lines = code.count("\n", start, end) + 1
        if lines > max_lines:
            long.append((path, line, name, lines))
        if string_error(ret):
            stringly.append((path, line, name, ret))
    return long, stringly


def workspace_members():
    with open("Cargo.toml", encoding="utf-8") as fh:
        text = fh.read()
    m = re.search(r"^members\s*=\s*\[(.*?)\]", text, re.S | re.M)
    return re.findall(r'"([^"]+)"', m.group(1)) if m else []


def main(argv):
    max_lines, quiet, crates = 150, False, []
    args = iter(argv)
    for a in args:
        if a == "--max-lines":
            max_lines = int(next(args))
        elif a == "--quiet":
            quiet = True
        elif a in ("-h", "--help"):
            print(__doc__)
            return 0
        else:
            crates.append(a.rstrip("/"))
    crates = crates or workspace_members()
    total_long = total_string = 0
    for crate in crates:
        long, stringly = [], []
        for path in rust_files(crate):
            a, b = scan(path, max_lines)
            long += a
            stringly += b
        total_long += len(long)
        total_string += len(stringly)
        print(f"{crate}: {len(long)} functions over {max_lines} lines, "
              f"{len(stringly)} returning Result<_, String>")
        if not quiet:
            for path, line, name, lines in sorted(long, key=lambda r: -r[3]):
                print(f"  long   {path}:{line} {name} ({lines} lines)")
            for path, line, name, ret in stringly:
                print(f"  string {path}:{line} {name} -> {ret}")
    print(f"total: {total_long} functions over {max_lines} lines, "
          f"{total_string} returning Result<_, String>")
    return 1 if total_long or total_string else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
