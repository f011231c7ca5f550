#!/usr/bin/env python3
"""The rooms of the code and the one direction between them (docs/layout.md, "Rooms").

Reads every `#include` of the sources and fails (exit 1, one line per violation) when
  1. a file includes a header of a room that its own room does not sit on (directly or through
     the rooms below), e.g. core/src/model/ including "step/...";
  2. a file includes a private header of another library (core/src/** from scenarios/, say):
     only tests/ and benchmarks/ may, through the CMake target nonholo_private_headers, and
     never by a relative path ("../core/src/...");
  3. cholmod.h, hdf5.h or mpi.h appears outside the files allowed to see them;
  4. a public header (<nonholo/...>) or a source folder has no room in the table;
  5. a .cpp does not open with a one-line comment saying what it holds.
The table of rooms is docs/layout.md's, so that the page and the check cannot disagree.

  tools/check_layers.py [--root DIR]            the check
  tools/check_layers.py --report [--units]      rooms, floors and arrows (--units: one room per
                                                file stem, as a flat folder would count them)
"""
import argparse
import os
import re
import sys
from collections import defaultdict

LIBRARY_SOURCES = ("sparse", "core", "reference", "mpi", "scenarios", "python/src")
# Where tests and benchmarks find private headers (the include directories of the CMake target
# nonholo_private_headers); each library's own files find them in its own src folder.
PRIVATE_ROOTS = {"core": "core/src", "scenarios": "scenarios/src", "sparse": "sparse/src", "mpi": "mpi/src",
                 "reference": "reference/src"}
# Headers of the heavy dependencies and the only files that may include them (rule 3).
GUARDED = [
    (re.compile(r"cholmod\.h$"), ("sparse/src/cholmod_ldlt.cpp",)),
    (re.compile(r"(hdf5|H5[A-Za-z]*)\.h$"), ("scenarios/src/output/",)),
    (re.compile(r"mpi\.h$"), ("mpi/", "scenarios/cli/mpi_")),
]
INCLUDE = re.compile(r'^\s*#\s*include\s*([<"])([^>"]+)[>"]', re.M)
SOURCE_EXTENSIONS = (".cpp", ".hpp", ".h", ".cc")
CHECKED_FOLDERS = ("sparse", "core", "reference", "mpi", "scenarios", "python/src", "tests", "benchmarks",
                   "examples")


def read_table(root):
    """The rooms of docs/layout.md: name -> (folders, public headers, rooms it sits on)."""
    text = open(os.path.join(root, "docs/layout.md"), encoding="utf-8").read()
    section = text.split("\n## Rooms\n", 1)
    if len(section) != 2:
        sys.exit("check_layers: docs/layout.md has no '## Rooms' section")
    rooms = {}
    for line in section[1].split("\n## ", 1)[0].splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 4 or not cells[0].startswith("`"):
            continue
        names = lambda cell: [w.strip("`") for w in re.findall(r"`[^`]+`", cell)]
        room, folders, headers, sits_on = names(cells[0])[0], names(cells[1]), names(cells[2]), names(cells[3])
        rooms[room] = (folders, headers, sits_on)
    for room, (_, _, sits_on) in rooms.items():
        for below in sits_on:
            if below not in rooms:
                sys.exit(f"check_layers: room {room} sits on {below}, which the table does not list")
    return rooms


def below(rooms):
    """room -> every room it may include (itself and all below it)."""
    seen = {}

    def visit(room, path):
        if room in seen:
            return seen[room]
        if room in path:
            sys.exit(f"check_layers: the table's rooms sit on each other in a circle: {' -> '.join(path + [room])}")
        allowed = {room}
        for b in rooms[room][2]:
            allowed |= visit(b, path + [room])
        seen[room] = allowed
        return allowed

    for room in rooms:
        visit(room, [])
    return seen


def sources(root):
    for top in CHECKED_FOLDERS:
        for folder, dirs, files in os.walk(os.path.join(root, top)):
            dirs[:] = sorted(d for d in dirs if d not in ("__pycache__", "corpus"))
            for f in sorted(files):
                if f.endswith(SOURCE_EXTENSIONS):
                    yield os.path.relpath(os.path.join(folder, f), root).replace(os.sep, "/")


def library_of(path):
    """The library a file belongs to for rule 2 (cli and python apart from scenarios)."""
    if path.startswith("scenarios/cli/"):
        return "cli"
    for lib in ("sparse", "core", "reference", "mpi", "scenarios", "python", "tests", "benchmarks", "examples"):
        if path.startswith(lib + "/"):
            return lib
    return None


class Rooms:
    def __init__(self, table):
        self.table = table
        self.allowed = below(table)
        self.folders = sorted(((f.rstrip("/") + "/", r) for r, (fs, _, _) in table.items() for f in fs),
                              key=lambda x: -len(x[0]))
        self.headers = {}
        self.header_globs = []
        for room, (_, headers, _) in table.items():
            for h in headers:
                if h.endswith("*"):
                    self.header_globs.append(("nonholo/" + h[:-1], room))
                else:
                    self.headers["nonholo/" + h] = room

    def of_file(self, path):
        """The room of a source file: by its public header name or by its folder."""
        for prefix in ("core/include/", "sparse/include/", "scenarios/include/", "reference/include/",
                       "mpi/include/"):
            if path.startswith(prefix):
                return self.of_public(path[len(prefix):])
        for folder, room in self.folders:
            if path.startswith(folder):
                return room
        return None

    def of_public(self, name):
        if name in self.headers:
            return self.headers[name]
        for prefix, room in self.header_globs:
            if name.startswith(prefix):
                return room
        return None


def resolve(root, path, spelled):
    """A quoted include: next to the file, else in a library's private root (as the build finds it)."""
    here = os.path.normpath(os.path.join(os.path.dirname(path), spelled)).replace(os.sep, "/")
    if os.path.exists(os.path.join(root, here)):
        return here
    own = library_of(path)
    for lib, private in sorted(PRIVATE_ROOTS.items(), key=lambda item: item[0] != own):
        candidate = f"{private}/{spelled}"
        if os.path.exists(os.path.join(root, candidate)):
            return candidate
    return None


def includes(root, path):
    text = open(os.path.join(root, path), encoding="utf-8", errors="replace").read()
    for m in INCLUDE.finditer(text):
        line = text.count("\n", 0, m.start()) + 1
        yield line, m.group(1), m.group(2)


def check(root):
    rooms = Rooms(read_table(root))
    problems = []
    for path in sources(root):
        lib = library_of(path)
        room = rooms.of_file(path)
        in_library = path.startswith(tuple(l + "/" for l in LIBRARY_SOURCES))
        if in_library and room is None:
            problems.append(f"{path}: in no room of docs/layout.md's table (add its folder or public header)")
        if path.endswith(".cpp"):
            first = open(os.path.join(root, path), encoding="utf-8").readline()
            if not first.startswith("//"):
                problems.append(f"{path}:1: opens without a one-line comment on what the file holds")
        for line, kind, spelled in includes(root, path):
            where = f"{path}:{line}: #include " + (f"<{spelled}>" if kind == "<" else f'"{spelled}"')
            for pattern, allowed in GUARDED:
                if pattern.search(spelled) and not path.startswith(allowed):
                    problems.append(f"{where}: only {', '.join(allowed)} may include it")
            if kind == "<":
                if not spelled.startswith("nonholo/"):
                    continue
                target_room = rooms.of_public(spelled)
                if target_room is None:
                    problems.append(f"{where}: the public header has no room in docs/layout.md's table")
                    continue
            else:
                if spelled.startswith("../") and lib in ("tests", "benchmarks", "examples"):
                    top = os.path.normpath(os.path.join(os.path.dirname(path), spelled)).split(os.sep)[0]
                    if top != lib:
                        problems.append(f"{where}: a relative path into {top}/: link nonholo_private_headers and "
                                        f"include it by its room path instead")
                        continue
                target = resolve(root, path, spelled)
                if target is None:
                    continue  # generated or system; the compiler says more
                target_lib = library_of(target)
                target_room = rooms.of_file(target)
                if target_lib != lib and lib not in ("tests", "benchmarks"):
                    problems.append(f"{where}: a private header of {target_lib} ({target}); use public headers "
                                    f"(<nonholo/...>) across libraries")
                    continue
                if spelled.startswith("../") and lib not in ("tests", "benchmarks", "examples"):
                    by_room = target[len(PRIVATE_ROOTS.get(lib, lib)) + 1:]
                    problems.append(f"{where}: include a private header by its room path ({by_room}), not by ../")
            if room is None or target_room is None or lib in ("tests", "benchmarks", "examples"):
                continue
            if target_room not in rooms.allowed[room]:
                problems.append(f"{where}: room {room} includes room {target_room}, which is above it or beside it "
                                f"(it sits on: {', '.join(sorted(rooms.allowed[room] - {room})) or 'nothing'})")
    return problems


def graph(root, units):
    """Edges between rooms (or file units) from the includes of the library sources."""
    rooms = None if units else Rooms(read_table(root))

    def node(path):
        if units:  # a flat folder's rooms: file stems, "x_internal" with "x", a public header with its .cpp
            stem = os.path.splitext(os.path.basename(path))[0]
            stem = re.sub(r"_internal$", "", stem)
            lib = library_of(path)
            return f"{'scenarios' if lib == 'cli' else lib}:{stem}"
        return rooms.of_file(path)

    edges = set()
    nodes = set()
    for path in sources(root):
        lib = library_of(path)
        if lib not in ("core", "scenarios", "cli"):
            continue
        a = node(path)
        if a is None:
            continue
        nodes.add(a)
        for _, kind, spelled in includes(root, path):
            if kind == "<":
                if not spelled.startswith("nonholo/"):
                    continue
                for prefix in ("core/include/", "scenarios/include/"):
                    if os.path.exists(os.path.join(root, prefix + spelled)):
                        target = prefix + spelled
                        break
                else:
                    continue  # sparse, reference, mpi, generated: other libraries
            else:
                target = resolve(root, path, spelled)
                if target is None:
                    continue
            b = node(target)
            if b is None or library_of(target) not in ("core", "scenarios", "cli"):
                continue
            nodes.add(b)
            if a != b:
                edges.add((a, b))
    return nodes, edges


def components(nodes, edges):
    """Strongly connected components (Tarjan), each a frozenset."""
    out = defaultdict(list)
    for a, b in edges:
        out[a].append(b)
    index, low, stack, on, comps = {}, {}, [], set(), []
    sys.setrecursionlimit(10000)

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in out[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = set()
            while True:
                w = stack.pop()
                on.discard(w)
                comp.add(w)
                if w == v:
                    break
            comps.append(frozenset(comp))

    for v in sorted(nodes):
        if v not in index:
            visit(v)
    return comps


def report(root, units):
    print(f"{'library':<10} {'rooms':>5} {'floors':>6} {'arrows':>6} {'in cycles':>9}  largest cycle")
    all_nodes, all_edges = graph(root, units)
    for lib in ("core", "scenarios"):
        pick = lambda n: (n.split(":")[0] if units else n.split("/")[0]) in ((lib,) if lib == "core" else ("scenarios", "cli"))
        nodes = {n for n in all_nodes if pick(n)}
        edges = {(a, b) for a, b in all_edges if a in nodes and b in nodes}
        comps = components(nodes, edges)
        comp_of = {n: c for c in comps for n in c}
        cyclic = sum(1 for a, b in edges if comp_of[a] is comp_of[b])
        floor = {}

        def height(c):  # floors: the longest path down the condensed graph, a cycle on one floor
            if c not in floor:
                floor[c] = 0
                floor[c] = 1 + max((height(comp_of[b]) for a, b in edges if a in c and comp_of[b] is not c),
                                   default=-1)
            return floor[c]

        floors = 1 + max(height(c) for c in comps)
        big = max(comps, key=len)
        show = f"{len(big)}: {', '.join(sorted(n.split(':')[-1] for n in big))}" if len(big) > 1 else "none"
        print(f"{lib:<10} {len(nodes):>5} {floors:>6} {len(edges):>6} {cyclic:>9}  {show}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--root", default=os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    parser.add_argument("--report", action="store_true", help="print rooms, floors and arrows instead")
    parser.add_argument("--units", action="store_true", help="with --report: one room per file stem")
    args = parser.parse_args()
    if args.report:
        report(args.root, args.units)
        return 0
    problems = check(args.root)
    for p in problems:
        print(p)
    if problems:
        print(f"check_layers: {len(problems)} problem(s); the rooms and their order are in docs/layout.md", file=sys.stderr)
        return 1
    print("check_layers: every include runs down (docs/layout.md)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
