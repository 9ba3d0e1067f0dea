#!/usr/bin/env python3
"""Fails (exit 1) when the crate's modules import each other in a circle.

How: every file under src/ is a module (src/a/b.rs and src/a/b/mod.rs are `a::b`; lib.rs and
main.rs are the root and are left out). A file depends on module `x::y` when its text, comments
and string literals removed, names `crate::x::y...` (in a `use` or a path), including grouped
imports `use crate::{a, b::c}` and `super::`/`self::` paths resolved against the file's own
module. A dependency on an item inside a module (`crate::a::b::Item`) counts as one on the
deepest module named (`a::b`). A module's own submodules (`mod x;`) are not dependencies of
it. Tests (`#[cfg(test)] mod tests { ... }` at the end of a file) are left out: they may reach
up. The dependency graph's strongly connected components (Tarjan) of more than one module are
the cycles; each is printed with one import per edge that closes it.

Usage: scripts/module_cycles.py [SRC_DIR]   (default: src next to this script's folder)
       scripts/module_cycles.py --self-test  (shows it catching cycles in small made-up crates)
"""
import os
import re
import sys


def strip_comments_and_strings(text):
    """The source with comments, string and char literals blanked (a small Rust lexer, so a
    `crate::` inside a string or a doc comment is not taken for a path)."""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
        elif text.startswith("/*", i):
            depth, i = 1, i + 2
            while i < n and depth:
                if text.startswith("/*", i):
                    depth, i = depth + 1, i + 2
                elif text.startswith("*/", i):
                    depth, i = depth - 1, i + 2
                else:
                    i += 1
            out.append(" ")
        elif c in "rb" and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")) and re.match(
            r'(?:br|r|b)(#*)"', text[i:]
        ) and (text[i] == "r" or text.startswith("br", i) or text.startswith('b"', i)):
            m = re.match(r'(?:br|r|b)(#*)"', text[i:])
            hashes = m.group(1)
            if text.startswith('b"', i):
                i += 1
                continue
            end = text.find('"' + hashes, i + m.end())
            i = n if end < 0 else end + 1 + len(hashes)
            out.append('""')
        elif c == '"':
            i += 1
            while i < n and text[i] != '"':
                i += 2 if text[i] == "\\" else 1
            i += 1
            out.append('""')
        elif c == "'":
            m = re.match(r"'(?:\\.[^']*|[^'\\])'", text[i:])
            if m:  # a char literal; otherwise a lifetime
                i += m.end()
                out.append("' '")
            else:
                out.append(c)
                i += 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


def without_tests(text):
    m = re.search(r"#\[cfg\(test\)\]\s*(pub(\([^)]*\))?\s+)?mod\s+\w+\s*\{", text)
    return text[: m.start()] if m else text


def module_of(src, path):
    rel = os.path.relpath(path, src)[:-3].split(os.sep)
    if rel[-1] == "mod":
        rel = rel[:-1]
    return tuple(rel)


def expand_use_tree(tree):
    """`a::{b, c::{d, e}}` -> [a::b, a::c::d, a::c::e] (as lists of segments)."""
    tree = tree.strip()
    i = tree.find("{")
    if i < 0:
        return [[s.strip() for s in tree.split(" as ")[0].split("::") if s.strip()]]
    prefix = [s for s in tree[:i].rstrip(":").split("::") if s.strip()]
    inner = tree[i + 1 : tree.rfind("}")]
    parts, depth, cur = [], 0, ""
    for ch in inner:
        if ch == "," and depth == 0:
            parts.append(cur)
            cur = ""
            continue
        depth += ch == "{"
        depth -= ch == "}"
        cur += ch
    parts.append(cur)
    out = []
    for p in parts:
        if p.strip():
            for tail in expand_use_tree(p):
                out.append(prefix + tail)
    return out


def resolve(segs, here):
    """Absolute module path segments of a path used in module `here`, or None if external."""
    if segs[0] == "crate":
        return segs[1:]
    if segs[0] in ("self", "super"):
        cur = list(here)
        rest = list(segs)
        while rest and rest[0] in ("self", "super"):
            if rest.pop(0) == "super":
                cur = cur[:-1]
        return cur + rest
    return None


def root_aliases(src, modules):
    """Modules re-exported at the crate root (`pub use stages::{features, ...};` in lib.rs),
    so `crate::features::X` is known to name `stages::features`."""
    lib = os.path.join(src, "lib.rs")
    if not os.path.exists(lib):
        return {}
    text = strip_comments_and_strings(open(lib, encoding="utf-8").read())
    aliases = {}
    for m in re.finditer(r"\bpub\s+use\s+([^;]+);", text):
        for segs in expand_use_tree(m.group(1)):
            if segs and segs[0] == "crate":
                segs = segs[1:]
            if tuple(segs) in modules:
                aliases[segs[-1]] = tuple(segs)
    return aliases


def deps_of(src, path, modules, aliases):
    here = module_of(src, path)
    text = without_tests(strip_comments_and_strings(open(path, encoding="utf-8").read()))
    found = []
    for m in re.finditer(r"\buse\s+([^;]+);", text):
        for segs in expand_use_tree(m.group(1)):
            found.append(segs)
    for m in re.finditer(r"\b((?:crate|super|self)(?:::\w+)+)", text):
        found.append(m.group(1).split("::"))
    deps = {}
    for segs in found:
        if not segs or segs[0] not in ("crate", "self", "super"):
            continue
        absolute = resolve(segs, here)
        if absolute is None:
            continue
        if absolute and absolute[0] in aliases and tuple(absolute[:1]) not in modules:
            absolute = list(aliases[absolute[0]]) + absolute[1:]
        # The deepest module named by the path.
        target = None
        for k in range(len(absolute), 0, -1):
            if tuple(absolute[:k]) in modules:
                target = tuple(absolute[:k])
                break
        if target is None or target == here:
            continue
        # A parent reaching into its own submodule is the module tree, not layering. (A
        # child naming an item of its parent, `super::Item`, is a real dependency.)
        if target[: len(here)] == here:
            continue
        deps.setdefault(target, "::".join(segs))
    return here, deps


def tarjan(graph):
    index, low, on, stack, out, counter = {}, {}, set(), [], [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, {}):
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
            out.append(comp)

    sys.setrecursionlimit(10000)
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def self_test():
    import tempfile

    cases = {
        # name: (files, expected cycle count)
        "direct use": ({"a.rs": "use crate::b::X;", "b.rs": "use crate::a::Y;"}, 1),
        "grouped use and inline path": (
            {"a.rs": "use crate::{c, b::X};", "b.rs": "fn f() { crate::a::g(); }", "c.rs": ""},
            1,
        ),
        "super path across a folder": (
            {"s/mod.rs": "mod t; mod u;", "s/t.rs": "use super::u::X;", "u.rs": "",
             "s/u.rs": "use crate::s::t::Y;"},
            1,
        ),
        "strings, comments and tests do not count": (
            {"a.rs": 'use crate::b::X; // crate::b', "b.rs": '/* crate::a */ const S: &str = "crate::a::x";'
             '\n#[cfg(test)]\nmod tests { use crate::a::Z; }'},
            0,
        ),
        "a module re-exported at the root": (
            {"lib.rs": "pub use s::{t};", "s/mod.rs": "pub mod t;", "s/t.rs": "use crate::u::X;",
             "u.rs": "use crate::t::Y;"},
            1,
        ),
        "a layered crate": ({"a.rs": "use crate::b::X;", "b.rs": "use crate::c::Y;", "c.rs": ""}, 0),
    }
    ok = True
    for name, (files, want) in cases.items():
        with tempfile.TemporaryDirectory() as d:
            for rel, text in files.items():
                os.makedirs(os.path.dirname(os.path.join(d, rel)), exist_ok=True)
                with open(os.path.join(d, rel), "w", encoding="utf-8") as f:
                    f.write(text)
            got = len(find_cycles(d)[1])
            print(f"self-test {name}: {got} cycle(s), expected {want}")
            ok &= got == want
    return 0 if ok else 1


def find_cycles(src):
    files = []
    for root, _, names in os.walk(src):
        for n in names:
            if n.endswith(".rs"):
                files.append(os.path.join(root, n))
    modules = {}
    for f in files:
        m = module_of(src, f)
        if m in (("lib",), ("main",)):
            continue
        modules[m] = f
    aliases = root_aliases(src, modules)
    graph = {}
    for m, f in sorted(modules.items()):
        _, deps = deps_of(src, f, modules, aliases)
        graph[m] = deps
    cycles = [sorted(c) for c in tarjan(graph) if len(c) > 1]
    return modules, cycles, graph


def main():
    if sys.argv[1:] == ["--self-test"]:
        return self_test()
    src = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "src")
    modules, cycles, graph = find_cycles(src)

    def name(m):
        return "::".join(m)

    if not cycles:
        print(f"module_cycles: {len(modules)} modules, no import cycle")
        return 0
    for c in cycles:
        members = set(c)
        print("cycle: " + " <-> ".join(name(m) for m in c))
        for m in c:
            for t, via in sorted(graph[m].items()):
                if t in members:
                    print(f"  {name(m)} uses {via}")
    return 1


if __name__ == "__main__":
    sys.exit(main())
