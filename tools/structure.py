#!/usr/bin/env python3
"""The structure check of issue 46: no arrow back up, no circle, no function over 120 lines.

Reads the Rust sources under src/ (standard library only, no cargo) and builds two graphs:

* rooms: the top-level modules of the library (`src/ingest/`, `src/stats.rs`, ...) and the
  binary's `cli` (src/main.rs and src/cli/). An arrow A -> B is one or more references from
  a file of room A to an item of room B: a `use crate::...`, `use super::...` or
  `use self::...` declaration, or a path written in code (`crate::x::y`, `super::f`, a child
  module's `child::f`; in the binary, `femto::x::y`). A path is followed through the `use`
  declarations of the modules it names to the module that defines the item, so an item
  re-exported by `ingest/mod.rs` but defined in `stats.rs` counts as a reference to `stats`.
  Comments and string literals are not read, nor is code under `#[cfg(test)]` (tests stand
  above everything they test).
* files inside each room, with the same arrows. A module using its own descendants (mod.rs
  calling or re-exporting its children) is ownership, not an arrow: the parent stands above
  the children it declares, and they may use the types it defines.

It reports
* every arrow that closes a circle between rooms (an arrow "back up": the rooms of each
  circle are put in the order that leaves the fewest references against it, and the arrows
  against that order are listed with the lines that make them);
* every circle among the files of one room, the same way;
* every function longer than 120 lines (from the line of `fn` to its closing brace), unless
  the comments or doc comment directly above it give a measured reason: the words "Long on
  purpose, measured:" followed by figures, e.g. `// Long on purpose, measured: 14.1 -> 12.9
  Mrays/s when split into ...`.

It prints the figures (rooms, floors, arrows; files and arrows inside rooms) and exits 1
when it finds anything, 0 otherwise.

Usage: tools/structure.py [--root DIR] [--max-lines N] [--verbose]
"""
import argparse
import os
import re
import sys
from collections import defaultdict

MAX_FN_LINES = 120
ITEM_KEYWORDS = {"fn", "struct", "enum", "trait", "type", "const", "static", "union", "mod"}


# --------------------------------------------------------------------------------------------
# Lexing: blank out comments and literals, keep line structure.


def strip_rust(text):
    """Returns `text` with comments, string, char and byte literals replaced by spaces.

    Newlines are kept so offsets map to the same line numbers.
    """
    out = []
    i, n = 0, len(text)

    def blank(s):
        return "".join(c if c == "\n" else " " for c in s)

    while i < n:
        c = text[i]
        if c == "/" and text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(blank(text[i:j]))
            i = j
        elif c == "/" and text.startswith("/*", i):
            depth, j = 1, i + 2
            while j < n and depth:
                if text.startswith("/*", j):
                    depth, j = depth + 1, j + 2
                elif text.startswith("*/", j):
                    depth, j = depth - 1, j + 2
                else:
                    j += 1
            out.append(blank(text[i:j]))
            i = j
        elif c in "rb" and re.match(r"(?:br|r)#*\"", text[i:i + 260]) and not _ident_before(text, i):
            m = re.match(r"(?:br|r)(#*)\"", text[i:])
            hashes = m.group(1)
            end = text.find('"' + hashes, i + m.end())
            j = n if end < 0 else end + 1 + len(hashes)
            out.append(blank(text[i:j]))
            i = j
        elif c == '"' or (c == "b" and text.startswith('b"', i) and not _ident_before(text, i)):
            j = i + (2 if c == "b" else 1)
            while j < n and text[j] != '"':
                j += 2 if text[j] == "\\" else 1
            j += 1
            out.append(blank(text[i:j]))
            i = j
        elif c == "'" or (c == "b" and text.startswith("b'", i) and not _ident_before(text, i)):
            start = i + (2 if c == "b" else 1)
            m = re.match(r"(?:\\(?:u\{[0-9a-fA-F_]+\}|x[0-9a-fA-F]{2}|.)|[^\\'\n])'", text[start:])
            if m:
                j = start + m.end()
                out.append(blank(text[i:j]))
                i = j
            else:  # a lifetime or a label
                out.append(c)
                i += 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


def _ident_before(text, i):
    return i > 0 and (text[i - 1].isalnum() or text[i - 1] == "_")


TOKEN_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*|::|->|=>|[{}()\[\];,*#!<>=:&]|\S")


def tokenize(stripped):
    """Tokens with their 1-based line numbers."""
    tokens = []
    line = 1
    pos = 0
    for m in TOKEN_RE.finditer(stripped):
        line += stripped.count("\n", pos, m.start())
        pos = m.start()
        tokens.append((m.group(0), line))
    return tokens


def is_ident(tok):
    return tok[0].isalpha() or tok[0] == "_"


# --------------------------------------------------------------------------------------------
# The module tree.


class Module:
    def __init__(self, path, file, crate):
        self.path = path  # tuple of names, crate root = ()
        self.file = file  # source file holding it (an inline module: its parent's file)
        self.crate = crate  # "lib" or "bin"
        self.children = {}  # name -> Module
        self.items = set()  # names defined here
        self.uses = defaultdict(list)  # visible name -> [(absolute path, line, is_pub)]
        self.globs = []  # (absolute module path, line, is_pub)
        self.test = False  # under #[cfg(test)]


class Crate:
    def __init__(self, name, root_file, src):
        self.name = name
        self.src = src
        self.root = Module((), root_file, name)
        self.modules = {(): self.root}
        self.refs = []  # (from module, absolute path, line, kind) with kind "use"/"code"/"pub-use"


def child_file(src, parent_file, parent_is_dir_owner, inline_path, name):
    """The file of module `name` declared in `parent_file` (inside inline modules `inline_path`)."""
    base = os.path.dirname(parent_file)
    if not parent_is_dir_owner:
        base = os.path.join(base, os.path.splitext(os.path.basename(parent_file))[0])
    base = os.path.join(base, *inline_path)
    for cand in (os.path.join(base, name + ".rs"), os.path.join(base, name, "mod.rs")):
        if os.path.exists(os.path.join(src, cand)):
            return cand
    return None


def dir_owner(file):
    return os.path.basename(file) in ("mod.rs", "lib.rs", "main.rs")


def parse_file(crate, module, file, texts):
    """Reads one file into `module` (and its inline submodules), recursing into `mod x;`."""
    raw = texts[file]
    stripped = strip_rust(raw)
    tokens = tokenize(stripped)
    # Attribute `#[path = ...]` on the next `mod`: its file lies outside this layout.
    raw_lines = raw.splitlines()
    path_attr_lines = {i + 1 for i, l in enumerate(raw_lines) if re.match(r"\s*#\[path\s*=", l)}
    scopes = [(module, 0, ())]  # (module, brace depth at which its items live, inline path)
    depth = 0
    pending_path_attr = False
    i = 0
    n = len(tokens)
    while i < n:
        tok, line = tokens[i]
        cur, base, inline = scopes[-1]
        if line in path_attr_lines:
            pending_path_attr = True
        if tok == "{":
            depth += 1
            i += 1
            continue
        if tok == "}":
            depth -= 1
            if len(scopes) > 1 and depth == scopes[-1][1] - 1:
                scopes.pop()
            i += 1
            continue
        if tok == "use" and (i == 0 or tokens[i - 1][0] not in ("::",)):
            is_pub = _visibility_before(tokens, i)
            j, trees = parse_use_tree(tokens, i + 1)
            for segs, alias, glob in trees:
                absolute = absolutize(crate, cur, segs)
                if absolute is None:
                    continue
                kind = "pub-use" if is_pub else "use"
                crate.refs.append((cur, absolute + (("*",) if glob else ()), line, kind))
                if depth == base:
                    if glob:
                        cur.globs.append((absolute, line, is_pub))
                    else:
                        name = alias or absolute[-1]
                        if name == "self":
                            name = absolute[-2] if len(absolute) > 1 else name
                            absolute = absolute[:-1]
                        if name != "_":
                            cur.uses[name].append((absolute, line, is_pub))
            i = j
            continue
        if tok == "mod" and i + 1 < n and is_ident(tokens[i + 1][0]):
            name = tokens[i + 1][0]
            nxt = tokens[i + 2][0] if i + 2 < n else ""
            if depth == base:
                cur.items.add(name)
            if nxt == ";":
                if not pending_path_attr and depth == base:
                    f = child_file(crate.src, file, dir_owner(file), inline, name)
                    if f is not None:
                        child = Module(cur.path + (name,), f, crate.name)
                        child.test = cur.test or cfg_test_above(raw_lines, line)
                        cur.children[name] = child
                        crate.modules[child.path] = child
                        parse_file(crate, child, f, texts)
                pending_path_attr = False
                i += 3
                continue
            if nxt == "{":
                child = Module(cur.path + (name,), file, crate.name)
                child.test = cur.test or cfg_test_above(raw_lines, line)
                cur.children[name] = child
                crate.modules[child.path] = child
                depth += 1
                scopes.append((child, depth, inline + (name,)))
                pending_path_attr = False
                i += 3
                continue
        if tok == "macro_rules" and i + 2 < n and tokens[i + 1][0] == "!" and depth == base:
            cur.items.add(tokens[i + 2][0])
        if tok in ITEM_KEYWORDS and depth == base and i + 1 < n and is_ident(tokens[i + 1][0]):
            prev = tokens[i - 1][0] if i else ""
            if prev not in ("::", ".", "&", "*") and not (tok == "type" and prev == "impl"):
                cur.items.add(tokens[i + 1][0])
        # Paths in code: crate::, super::, self::, femto:: (binary), or a child module's name.
        if is_ident(tok) and i + 1 < n and tokens[i + 1][0] == "::" and (i == 0 or tokens[i - 1][0] != "::"):
            segs, j = read_path(tokens, i)
            head = segs[0]
            absolute = None
            if head in ("crate", "super", "self") or (head == "femto" and crate.name == "bin"):
                absolute = absolutize(crate, cur, segs)
            elif head in cur.children:
                absolute = cur.path + tuple(segs)
            elif head in cur.uses and head not in ("std", "core", "alloc"):
                # a name brought in by `use`: the use already made the arrow; follow it for the item
                absolute = None
            if absolute is not None:
                crate.refs.append((cur, absolute, line, "code"))
            i = j
            continue
        i += 1


def cfg_test_above(raw_lines, line):
    """Whether the `mod` on 1-based `line` carries `#[cfg(test)]` (on its line or above)."""
    k = line - 1
    if "#[cfg(test)]" in raw_lines[k]:
        return True
    k -= 1
    while k >= 0:
        s = raw_lines[k].strip()
        if s.startswith("#[cfg(test)]"):
            return True
        if not (s.startswith("#[") or s.startswith("//")):
            return False
        k -= 1
    return False


def _visibility_before(tokens, i):
    """Whether the `use` at token `i` is `pub` (any scope)."""
    j = i - 1
    if j >= 0 and tokens[j][0] == ")":
        while j >= 0 and tokens[j][0] != "(":
            j -= 1
        j -= 1
    return j >= 0 and tokens[j][0] == "pub"


def read_path(tokens, i):
    segs = [tokens[i][0]]
    j = i + 1
    while j + 1 < len(tokens) and tokens[j][0] == "::" and is_ident(tokens[j + 1][0]):
        segs.append(tokens[j + 1][0])
        j += 2
    return segs, j


def parse_use_tree(tokens, i):
    """Parses a use tree from token i to `;`; returns (index after `;`, [(segs, alias, glob)])."""
    out = []

    def tree(j, prefix):
        if tokens[j][0] == "::":
            j += 1
        segs = list(prefix)
        while True:
            t = tokens[j][0]
            if t == "{":
                j += 1
                while tokens[j][0] != "}":
                    j = tree(j, segs)
                    if tokens[j][0] == ",":
                        j += 1
                return j + 1
            if t == "*":
                out.append((segs, None, True))
                return j + 1
            if is_ident(t):
                segs.append(t)
                j += 1
                if tokens[j][0] == "::":
                    j += 1
                    continue
                alias = None
                if tokens[j][0] == "as":
                    alias = tokens[j + 1][0]
                    j += 2
                out.append((segs, alias, False))
                return j
            return j + 1

    j = tree(i, [])
    while j < len(tokens) and tokens[j][0] != ";":
        j += 1
    return j + 1, out


def absolutize(crate, cur, segs):
    """An absolute module path (crate root = ()) for a path written in module `cur`, or None
    for a path into another crate (std, nalgebra, ...)."""
    segs = list(segs)
    if not segs:
        return None
    head = segs[0]
    if head == "crate":
        return tuple(segs[1:])
    if head == "femto" and crate.name == "bin":
        return ("@lib",) + tuple(segs[1:])
    if head in ("self", "super"):
        path = list(cur.path)
        while segs and segs[0] in ("self", "super"):
            if segs[0] == "super":
                if not path:
                    return None
                path.pop()
            segs.pop(0)
        return tuple(path) + tuple(segs)
    if head in cur.children:
        return cur.path + tuple(segs)
    return None


# --------------------------------------------------------------------------------------------
# Resolution: a path to the module that defines the item.


def resolve(crates, crate, path, seen=None):
    """The module (of `crate` or of the library) that defines `path`, or the deepest one named."""
    if path and path[0] == "@lib":
        crate, path = crates["lib"], path[1:]
    seen = seen or set()
    key = (crate.name, path)
    if key in seen:
        return None
    seen.add(key)
    mod = crate.root
    for k, seg in enumerate(path):
        if seg == "*":
            return mod
        if seg in mod.children:
            mod = mod.children[seg]
            continue
        if seg in mod.items:
            return mod
        if seg in mod.uses:
            for target, _line, _pub in mod.uses[seg]:
                r = resolve(crates, crate, target + tuple(path[k + 1:]), seen)
                if r is not None:
                    return r
            return mod
        for target, _line, _pub in mod.globs:
            r = resolve_glob(crates, crate, target, seg, seen)
            if r is not None:
                return r
        return mod
    return mod


def resolve_glob(crates, crate, target, name, seen):
    """The module defining `name` if the glob import `target::*` brings it, else None."""
    src = resolve(crates, crate, target, set(seen))
    if src is None:
        return None
    owner = crates["lib"] if src.crate == "lib" else crate
    if name in src.items or name in src.children:
        return src
    if name in src.uses:
        return resolve(crates, owner, src.path + (name,), seen)
    for t, _l, _p in src.globs:
        r = resolve_glob(crates, owner, t, name, seen | {(owner.name, src.path)})
        if r is not None:
            return r
    return None


def room_of(mod):
    if mod.crate == "bin":
        return "cli"
    return mod.path[0] if mod.path else "lib"


def is_descendant(path, ancestor):
    return len(path) > len(ancestor) and path[: len(ancestor)] == ancestor


# --------------------------------------------------------------------------------------------
# Graphs.


def strongly_connected(nodes, edges):
    """Tarjan's algorithm; edges: dict node -> set(node). Returns a list of components."""
    index, low, on, stack, comps = {}, {}, set(), [], []
    counter = [0]

    def visit(v):
        work = [(v, iter(sorted(edges.get(v, ()))))]
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        while work:
            node, it = work[-1]
            advanced = False
            for w in it:
                if w not in index:
                    index[w] = low[w] = counter[0]
                    counter[0] += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(edges.get(w, ())))))
                    advanced = True
                    break
                if w in on:
                    low[node] = min(low[node], index[w])
            if advanced:
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                comp = []
                while True:
                    w = stack.pop()
                    on.discard(w)
                    comp.append(w)
                    if w == node:
                        break
                comps.append(sorted(comp))

    for v in sorted(nodes):
        if v not in index:
            visit(v)
    return comps


def back_arrows(comp, weight):
    """Orders the nodes of one circle so that the fewest references run against the order
    (greedy, Eades-Lin-Smyth, weighted), and returns the arrows against it."""
    remaining = set(comp)
    left, right = [], []

    def w_in(v):
        return sum(weight.get((u, v), 0) for u in remaining if u != v)

    def w_out(v):
        return sum(weight.get((v, u), 0) for u in remaining if u != v)

    while remaining:
        changed = True
        while changed:
            changed = False
            for v in sorted(remaining):
                if w_out(v) == 0:  # imports nothing left: lowest
                    right.insert(0, v)
                    remaining.discard(v)
                    changed = True
                elif w_in(v) == 0:  # imported by nothing left: highest
                    left.append(v)
                    remaining.discard(v)
                    changed = True
        if remaining:
            v = max(sorted(remaining), key=lambda x: w_out(x) - w_in(x))
            left.append(v)
            remaining.discard(v)
    order = left + right  # higher first: arrows should point rightwards (down)
    pos = {v: k for k, v in enumerate(order)}
    back = [(u, v) for (u, v) in weight if u in pos and v in pos and u != v and pos[u] > pos[v]]
    return order, sorted(back)


def floors(nodes, edges):
    """The number of floors: the longest chain of arrows through the graph of circles."""
    comps = strongly_connected(nodes, edges)
    comp_of = {v: k for k, c in enumerate(comps) for v in c}
    level = {}
    # Tarjan emits components in reverse topological order (sinks first).
    for k, c in enumerate(comps):
        below = [level[comp_of[w]] for v in c for w in edges.get(v, ()) if comp_of[w] != k]
        level[k] = 1 + max(below, default=0)
    return max(level.values(), default=0)


# --------------------------------------------------------------------------------------------
# Long functions.


def long_functions(file, raw, stripped, limit):
    tokens = tokenize(stripped)
    raw_lines = raw.splitlines()
    found = []
    n = len(tokens)
    for i, (tok, line) in enumerate(tokens):
        if tok != "fn" or i + 1 >= n or not is_ident(tokens[i + 1][0]):
            continue
        name = tokens[i + 1][0]
        j, paren = i + 2, 0
        while j < n:
            t = tokens[j][0]
            if t in "([":
                paren += 1
            elif t in ")]":
                paren -= 1
            elif paren == 0 and t in ("{", ";"):
                break
            j += 1
        if j >= n or tokens[j][0] == ";":
            continue
        depth, k = 0, j
        while k < n:
            t = tokens[k][0]
            if t == "{":
                depth += 1
            elif t == "}":
                depth -= 1
                if depth == 0:
                    break
            k += 1
        end = tokens[k][1] if k < n else tokens[-1][1]
        length = end - line + 1
        if length > limit and not measured_reason(raw_lines, line):
            found.append((file, line, name, length))
    return found


def measured_reason(raw_lines, fn_line):
    """Whether the comments and attributes directly above line `fn_line` give a measured
    reason: "Long on purpose, measured:" followed by a figure."""
    block = []
    k = fn_line - 2
    while k >= 0:
        s = raw_lines[k].strip()
        if s.startswith("//") or s.startswith("#[") or s.startswith("*") or s.startswith("/*"):
            block.append(s)
            k -= 1
        else:
            break
    text = " ".join(b.lstrip("/*! ") for b in reversed(block) if not b.startswith("#["))
    m = re.search(r"(?i)long on purpose, measured:(.*)", text)
    return m is not None and re.search(r"\d", m.group(1)) is not None


# --------------------------------------------------------------------------------------------


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--root", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    ap.add_argument("--max-lines", type=int, default=MAX_FN_LINES)
    ap.add_argument("--verbose", action="store_true", help="list every room, its floor and arrows")
    ap.add_argument("--known", help="a file of findings still open (one key a line, as printed "
                    "after 'key:'): reported, but only a finding not listed fails")
    args = ap.parse_args()
    src = os.path.join(os.path.abspath(args.root), "src")

    texts = {}
    for dirpath, _dirs, files in os.walk(src):
        for f in files:
            if f.endswith(".rs"):
                rel = os.path.relpath(os.path.join(dirpath, f), src)
                with open(os.path.join(dirpath, f), encoding="utf-8") as fh:
                    texts[rel] = fh.read()

    crates = {}
    for name, root in (("lib", "lib.rs"), ("bin", "main.rs")):
        if root in texts:
            crate = Crate(name, root, src)
            crates[name] = crate
            parse_file(crate, crate.root, root, texts)

    # References -> arrows between files and rooms.
    file_room = {}
    for crate in crates.values():
        for mod in crate.modules.values():
            file_room[mod.file] = room_of(mod)
    file_weight = defaultdict(int)
    file_where = defaultdict(list)
    for crate in crates.values():
        for cur, path, line, kind in crate.refs:
            target = resolve(crates, crate, path)
            if target is None or target.file == cur.file or cur.test:
                continue
            if target.crate == cur.crate and is_descendant(target.path, cur.path):
                continue  # a module using its own children: ownership, not an arrow
            a, b = cur.file, target.file
            file_weight[(a, b)] += 1
            file_where[(a, b)].append(line)

    room_weight = defaultdict(int)
    room_where = defaultdict(list)
    for (a, b), w in file_weight.items():
        ra, rb = file_room[a], file_room[b]
        if ra != rb:
            room_weight[(ra, rb)] += w
            room_where[(ra, rb)].append((a, b))
    rooms = sorted(set(file_room.values()) - {"lib"})
    room_edges = defaultdict(set)
    for (a, b) in room_weight:
        if a != "lib" and b != "lib":
            room_edges[a].add(b)

    problems = 0
    out = []
    keys = []

    # Circles between rooms.
    for comp in strongly_connected(rooms, room_edges):
        if len(comp) < 2:
            continue
        order, back = back_arrows(comp, {k: v for k, v in room_weight.items() if k[0] in comp and k[1] in comp})
        out.append(f"circle between rooms: {' > '.join(order)} (higher first)")
        for a, b in back:
            problems += 1
            keys.append(f"arrow back up {a} -> {b}")
            out.append(f"  arrow back up: {a} -> {b}")
            for fa, fb in room_where[(a, b)]:
                lines = ",".join(str(x) for x in sorted(set(file_where[(fa, fb)])))
                out.append(f"    src/{fa}:{lines} -> src/{fb}")

    # Circles among the files of each room.
    room_files = defaultdict(list)
    for f, r in file_room.items():
        room_files[r].append(f)
    inner_arrows = 0
    total_floors = 0
    for r in sorted(room_files):
        files = sorted(room_files[r])
        edges = defaultdict(set)
        weight = {}
        for (a, b), w in file_weight.items():
            if a in files and b in files:
                edges[a].add(b)
                weight[(a, b)] = w
        inner_arrows += len(weight)
        total_floors = max(total_floors, floors(files, edges))
        for comp in strongly_connected(files, edges):
            if len(comp) < 2:
                continue
            problems += 1
            keys.append(f"circle in room {r}")
            order, back = back_arrows(comp, weight)
            out.append(f"circle in room {r}: {' <-> '.join('src/' + f for f in order)}")
            for a, b in back:
                lines = ",".join(str(x) for x in sorted(set(file_where[(a, b)])))
                out.append(f"  src/{a}:{lines} -> src/{b}")

    # Long functions.
    longs = []
    for f in sorted(texts):
        longs += long_functions(f, texts[f], strip_rust(texts[f]), args.max_lines)
    for f, line, name, length in sorted(longs, key=lambda x: -x[3]):
        problems += 1
        keys.append(f"function src/{f} {name}")
        out.append(f"function over {args.max_lines} lines: {length} src/{f}:{line} {name}")

    room_floor_count = floors(rooms, room_edges)
    if args.verbose:
        for r in rooms:
            out.append(f"room {r}: -> {', '.join(sorted(room_edges[r]))}")
    arrows = sum(len(v) for v in room_edges.values())
    print("\n".join(out))
    print(
        f"structure: {len(rooms)} rooms on {room_floor_count} floors, {arrows} arrows between rooms; "
        f"{len(file_room)} files, {inner_arrows} arrows inside rooms; "
        f"{problems} found ({len(longs)} functions over {args.max_lines} lines)"
    )
    known = set()
    if args.known:
        with open(args.known, encoding="utf-8") as fh:
            known = {l.strip() for l in fh if l.strip() and not l.startswith("#")}
    new = [k for k in keys if k not in known]
    if known:
        print(f"{problems - len(new)} of them listed in {args.known} (still open); new: {len(new)}")
        for k in new:
            print(f"  new: {k}")
    return 1 if new else 0


if __name__ == "__main__":
    sys.exit(main())
