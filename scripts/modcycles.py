#!/usr/bin/env python3
"""Module cycles of the workspace's crates, at two levels: the top-level modules of one crate
that reach each other through `crate::` paths, and the files (each file is a module) of one
crate that reach each other through `crate::`, `super::`, `self::` or child-module paths (a
pair that use each other, or a longer circle a -> b -> c -> a).

Prints one `CYCLE` line per circle found and exits 1 when there is any; prints `checked` and
exits 0 when there is none. Both levels always run (CI runs it with no arguments):

    python3 scripts/modcycles.py

What counts as a use: a `crate::m` path in code, including grouped imports
(`use crate::{a::X, b}`); at file level also `super::x`, `self::x` and `child::x` for a
`mod child;` the file declares, grouped ones included (`use super::{x::Y, Z}`). A path names the longest module it starts with: `crate::a::b::C`
is a use of file `a/b.rs` (or `a/b/mod.rs`) when it exists, else of `a`. Declaring a child
(`mod b;`) is not a use of it. Comments (doc links among them) are not uses, and neither are
`#[cfg(test)]` modules: a test may drive a module through its caller without the shipped
modules depending on each other.
"""
import os
import re
import sys

def crates():
    """The `src` folder of every workspace member (the root `Cargo.toml`'s `members`)."""
    with open('Cargo.toml') as fh:
        m = re.search(r'members\s*=\s*\[([^\]]*)\]', fh.read())
    names = re.findall(r'"([^"]+)"', m.group(1)) if m else []
    return [os.path.join(n, 'src') for n in names if os.path.isdir(os.path.join(n, 'src'))]


def strip_comments(txt):
    """The text without `//` and `/* */` comments; string literals are kept (a `//` in a
    string does not start a comment)."""
    out, i, n = [], 0, len(txt)
    while i < n:
        c = txt[i]
        if c == '"':
            j = i + 1
            while j < n and txt[j] != '"':
                j += 2 if txt[j] == '\\' else 1
            out.append(txt[i:j + 1])
            i = j + 1
        elif txt.startswith('//', i):
            j = txt.find('\n', i)
            i = n if j < 0 else j
        elif txt.startswith('/*', i):
            depth, j = 1, i + 2
            while j < n and depth:
                if txt.startswith('/*', j):
                    depth, j = depth + 1, j + 2
                elif txt.startswith('*/', j):
                    depth, j = depth - 1, j + 2
                else:
                    j += 1
            i = j
        else:
            out.append(c)
            i += 1
    return ''.join(out)


def strip_test_modules(txt):
    """The text without `#[cfg(test)] mod name { ... }` blocks."""
    while True:
        m = re.search(r'#\[cfg\(test\)\]\s*(pub(\([^)]*\))?\s+)?mod\s+\w+\s*\{', txt)
        if not m:
            return txt
        depth, j = 1, m.end()
        while j < len(txt) and depth:
            depth += {'{': 1, '}': -1}.get(txt[j], 0)
            j += 1
        txt = txt[:m.start()] + txt[j:]


def uses(txt):
    """The top-level modules named by `crate::` paths in `txt`."""
    found = set(re.findall(r'crate::(\w+)', txt))
    for group in re.findall(r'crate::\{([^;]*)\}', txt):
        # Top-level names of the group: the first segment of each comma-separated item at
        # brace depth 0.
        depth, item = 0, ''
        for ch in group + ',':
            if ch == '{':
                depth += 1
            elif ch == '}':
                depth -= 1
            if ch == ',' and depth == 0:
                m = re.match(r'\s*(\w+)', item)
                if m:
                    found.add(m.group(1))
                item = ''
            else:
                item += ch
    return found


def modules(crate):
    """Top-level module -> the other top-level modules it uses."""
    mods = {}
    for root, _, files in os.walk(crate):
        for f in sorted(files):
            if not f.endswith('.rs'):
                continue
            p = os.path.join(root, f)
            top = os.path.relpath(p, crate)[:-3].split(os.sep)[0]
            if top in ('lib', 'main', 'bin'):
                continue
            with open(p) as fh:
                txt = strip_test_modules(strip_comments(fh.read()))
            mods.setdefault(top, set()).update(u for u in uses(txt) if u != top)
    return {m: {u for u in us if u in mods} for m, us in mods.items()}


def cycles(graph):
    """One circle per strongly connected component of more than one module (Tarjan), as the
    list of its modules in order, the first repeated at the end."""
    index, low, stack, on, comps, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
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
                comps.append(set(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    out = []
    for comp in comps:
        # A shortest circle through the component's first module (breadth-first).
        start = min(comp)
        prev, frontier, found = {start: None}, [start], None
        while frontier and found is None:
            nxt = []
            for v in frontier:
                for w in sorted(graph[v] & comp):
                    if w == start:
                        found = v
                        break
                    if w not in prev:
                        prev[w] = v
                        nxt.append(w)
                if found is not None:
                    break
            frontier = nxt
        path, v = [], found
        while v is not None:
            path.append(v)
            v = prev[v]
        out.append(list(reversed(path)) + [start])
    return out


def module_path(crate, path):
    """The module path of a source file: `a/b.rs` and `a/b/mod.rs` are `a::b`; `lib.rs` and
    `main.rs` are the crate root `''`; a file under `bin/` is `None` (a crate of its own)."""
    parts = os.path.relpath(path, crate)[:-3].split(os.sep)
    if parts[0] == 'bin':
        return None
    if parts[-1] == 'mod' or (len(parts) == 1 and parts[0] in ('lib', 'main')):
        parts = parts[:-1]
    return '::'.join(parts)


def test_files(crate):
    """Files declared as test modules (`#[cfg(test)] mod x;`), by module path."""
    out = set()
    for root, _, files in os.walk(crate):
        for f in files:
            if not f.endswith('.rs'):
                continue
            p = os.path.join(root, f)
            me = module_path(crate, p)
            if me is None:
                continue
            with open(p) as fh:
                txt = strip_comments(fh.read())
            for name in re.findall(r'#\[cfg\(test\)\]\s*(?:pub(?:\([^)]*\))?\s+)?mod\s+(\w+)\s*;', txt):
                out.add(f'{me}::{name}' if me else name)
    return out


def paths_at(txt, m):
    """The paths a match names after its prefix (group 1, e.g. `super::` or `child::`): one,
    or for a group (`prefix::a::{b, c::D}`) one per item, each as its list of segments (the
    prefix's own segments other than `super` and `self` included)."""
    head = [x for x in m.group(1).split('::') if x and x not in ('super', 'self')]
    mid = [x for x in m.group(2).split('::') if x]
    if m.group(3) != '{':
        return [head + mid + [m.group(3)]]
    depth, j = 1, m.end()
    while j < len(txt) and depth:
        depth += {'{': 1, '}': -1}.get(txt[j], 0)
        j += 1
    items = re.findall(r'(\w+(?:::\w+)*)', txt[m.end():j - 1])
    return [head + mid + item.split('::') for item in items if item != 'self'] or [head + mid]


def file_modules(crate):
    """Each file's module -> the other files' modules it uses (see the module doc)."""
    texts, known = {}, set()
    for root, _, files in os.walk(crate):
        for f in sorted(files):
            if f.endswith('.rs'):
                p = os.path.join(root, f)
                me = module_path(crate, p)
                if me is not None:
                    with open(p) as fh:
                        texts[me] = strip_test_modules(strip_comments(fh.read()))
                    known.add(me)
    tests = test_files(crate)
    tests = {m for m in known if any(m == t or m.startswith(t + '::') for t in tests)}

    def resolve(segs):
        for k in range(len(segs), 0, -1):
            cand = '::'.join(segs[:k])
            if cand in known:
                return cand
        return ''

    graph = {}
    for me, txt in texts.items():
        if me in tests:
            continue
        here = me.split('::') if me else []
        used = set()
        for path in re.findall(r'\bcrate((?:::\w+)+)', txt):
            used.add(resolve(path.strip(':').split('::')))
        for group in re.findall(r'\bcrate::\{([^;]*)\}', txt):
            for item in re.findall(r'(\w+(?:::\w+)*)', group):
                used.add(resolve(item.split('::')))
        for m in re.finditer(r'(?<![\w:])((?:super::)+)((?:\w+::)*)(\w+|\{)', txt):
            up = m.group(1).count('super')
            # A `mod.rs` file is its folder's module: `super` climbs from it like from a.rs.
            base = here[:len(here) - up] if up <= len(here) else []
            for tail in paths_at(txt, m):
                used.add(resolve(base + [s for s in tail if s != 'super']))
        children = re.findall(r'\bmod\s+(\w+)\s*;', txt)
        for child in children:
            for m in re.finditer(r'(?<![\w:])(?:self::)?(' + child + r'::)((?:\w+::)*)(\w+|\{)', txt):
                for tail in paths_at(txt, m):
                    used.add(resolve(here + tail))
        for m in re.finditer(r'(?<![\w:])self::()((?:\w+::)*)(\w+|\{)', txt):
            for tail in paths_at(txt, m):
                used.add(resolve(here + tail))
        graph[me] = {u for u in used if u != me and u not in tests}
    return {m: {u for u in us if u in graph} for m, us in graph.items()}


def main():
    found = 0
    for crate in crates():
        for circle in cycles(modules(crate)):
            print(crate, 'CYCLE', ' -> '.join(circle))
            found += 1
        for circle in cycles(file_modules(crate)):
            print(crate, 'CYCLE (files)', ' -> '.join(c or '(crate root)' for c in circle))
            found += 1
    print('checked')
    return 1 if found else 0


if __name__ == '__main__':
    sys.exit(main())
