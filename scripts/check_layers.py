#!/usr/bin/env python3
"""The layering rules of docs/architecture.md, checked on src/udvr's include graph (every .h and
.cpp, tests included):

1. The core — util/, data/, stats/, reconstruct/, classify/, render/ — reaches, directly or
   through other headers (quoted includes beside the file, "../io/x.h", count as well), no header under io/, eval/, cmd/, serve/ and no foreign library
   header (VTK, NetCDF, HDF5, libpng, zlib, Cairo, cpp-httplib, CLI11, pybind11, MPI).
2. No two directories include each other, directly or around a longer cycle.
3. The ParaView plugin (paraview/) includes only core headers of udvr: ParaView's process
   carries ParaView's own VTK, and io/ links Debian's (two VTKs in one process clash).
4. netCDF-C's and HDF5's headers are included only by the files of NETCDF_FILES: every call
   into those libraries is then made there, where it holds netcdfLibraryMutex, the lock the
   HDF5 probe forks under (docs/architecture.md, "NetCDF, HDF5 and threads").
5. One SIMD vocabulary: only the files of SIMD_FILES (util/lanes.h and its test) include an
   intrinsics header (<immintrin.h>, <arm_neon.h> …), name an intrinsic or its register types
   (_mm256_loadu_ps, __m512, __mmask16, vfmaq_f32, float32x4_t, a register shuffle by
   __builtin_shufflevector or __builtin_ia32_* …) or define a vector type
   (vector_size); everything else says it in lanes.h's vocabulary (Vf, Vec<E, W>, loadHalves …).
   Comments and string literals are not checked.

Prints each violation with the chain of includes that makes it, and exits 1 if there is any.
    python3 scripts/check_layers.py [SRC_ROOT]      (default: src/ beside this script's folder)
"""
import pathlib
import re
import sys

CORE = ("util", "data", "stats", "reconstruct", "classify", "render")
ABOVE_CORE = ("io", "eval", "cmd", "serve")
FOREIGN = re.compile(
    r"^(vtk|netcdf|hdf5|H5|png\.h|pngconf|zlib\.h|zconf|cairo|httplib|CLI/|pybind11|Python\.h|mpi)",
    re.IGNORECASE)
# The only files that may include netCDF-C's or HDF5's headers (rule 4); tests write fixtures.
NETCDF_HEADER = re.compile(r"^(netcdf|hdf5|H5)", re.IGNORECASE)
NETCDF_FILES = ("udvr/io/netcdf_access.h", "udvr/io/netcdf_access.cpp", "udvr/io/netcdf_io.cpp",
                "udvr/io/netcdf_io_test.cpp")
# The only files that may use intrinsics or define vector types (rule 5).
SIMD_FILES = ("udvr/util/lanes.h", "udvr/util/lanes_test.cpp")
SIMD_HEADER = re.compile(r"^(\w*intrin\.h|arm_neon\.h|arm_sve\.h|arm_acle\.h)$")
SIMD_USE = re.compile(
    r"\b(_mm\d*_\w+|__m(64|128|256|512)[a-z]*|__mmask\d+|(__)?vector_size(__)?|ext_vector_type|"
    r"__builtin_shufflevector|__builtin_ia32_\w+|"
    r"v\w+q_[fsu]\d+|(float|int|uint)\d+x\d+_t)\b")
# Rule 5 also covers the C++ beside the library: benchmarks, tests, bindings, the plugin.
SIMD_OTHER_DIRS = ("bench", "tests", "python", "paraview", "fuzz")
CXX_SUFFIXES = (".h", ".hpp", ".cpp", ".cc", ".cxx", ".cu")
INCLUDE = re.compile(r'^\s*#\s*include\s*([<"])([^>"]+)[>"]', re.MULTILINE)


def scan(src):
    """{file: [(kind, target)]}, file relative to src (udvr/...); kind 'udvr' or 'system'."""
    graph = {}
    for path in sorted((src / "udvr").rglob("*")):
        if path.suffix not in (".h", ".cpp") or not path.is_file():
            continue
        rel = path.relative_to(src).as_posix()
        edges = []
        for m in INCLUDE.finditer(path.read_text(errors="replace")):
            target = m.group(2)
            if target.startswith("udvr/"):
                edges.append(("udvr", target))
                continue
            # A quoted include found beside the including file ("../io/x.h") is that file.
            beside = (path.parent / target).resolve()
            if m.group(1) == '"' and beside.is_file():
                try:
                    edges.append(("udvr", beside.relative_to(src.resolve()).as_posix()))
                    continue
                except ValueError:  # outside src/: a header of the build or another tree
                    pass
            edges.append(("system", target))
        graph[rel] = edges
    return graph


def directory(rel):
    parts = rel.split("/")
    return parts[1] if len(parts) > 2 else ""


def core_violations(graph):
    """(file, chain) for each core file that reaches a forbidden header."""
    out = []
    for start in sorted(graph):
        if directory(start) not in CORE:
            continue
        seen = {start}
        stack = [(start, [start])]
        found = None
        while stack and not found:
            node, chain = stack.pop()
            for kind, target in graph.get(node, []):
                if kind == "system":
                    if FOREIGN.match(target):
                        found = chain + ["<%s>" % target]
                        break
                    continue
                if directory(target) in ABOVE_CORE:
                    found = chain + [target]
                    break
                if target not in seen and target in graph:
                    seen.add(target)
                    stack.append((target, chain + [target]))
        if found:
            out.append(found)
    return out


def plugin_violations(repo):
    """(file, include) for each udvr header outside the core that paraview/ includes."""
    out = []
    for path in sorted((repo / "paraview").rglob("*")):
        if path.suffix not in (".h", ".cxx", ".cpp") or not path.is_file():
            continue
        for m in INCLUDE.finditer(path.read_text(errors="replace")):
            target = m.group(2)
            if target.startswith("udvr/") and directory(target) not in CORE:
                out.append((path.relative_to(repo).as_posix(), target))
    return out


def netcdf_violations(graph):
    """(file, header) for each netCDF-C or HDF5 header included outside NETCDF_FILES."""
    return [(rel, target) for rel, incs in sorted(graph.items()) for kind, target in incs
            if rel not in NETCDF_FILES and ((kind == "system" and NETCDF_HEADER.match(target)) or
                                            target == "udvr/io/netcdf_access.h")]


def strip_comments_and_strings(text):
    """text with its comments and string/char literals blanked (newlines kept, so line numbers
    stay)."""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append("\n" * text.count("\n", i, j))
            i = j
        elif c in "\"'":
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            out.append(c + c)
            i = j + 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


def simd_violations(src):
    """(file, line, what) for each intrinsics header, intrinsic or vector type outside
    SIMD_FILES, in src/udvr and the C++ of SIMD_OTHER_DIRS (file relative to src, or to the
    repository for those)."""
    files = [(path, path.relative_to(src).as_posix()) for path in sorted((src / "udvr").rglob("*"))]
    for d in SIMD_OTHER_DIRS:
        files += [(path, path.relative_to(src.parent).as_posix())
                  for path in sorted((src.parent / d).rglob("*"))]
    out = []
    for path, rel in files:
        if rel in SIMD_FILES or path.suffix not in CXX_SUFFIXES or not path.is_file():
            continue
        code = strip_comments_and_strings(path.read_text(errors="replace"))
        for number, line in enumerate(code.split("\n"), 1):
            include = re.match(r"\s*#\s*include\s*<([^>]+)>", line)
            if include:
                if SIMD_HEADER.match(include.group(1)):
                    out.append((rel, number, "<%s>" % include.group(1)))
                continue
            for m in SIMD_USE.finditer(line):
                out.append((rel, number, m.group(0)))
    return out


def directory_cycles(graph):
    """Each cycle of the directory graph (as a list of directories), with one include per edge."""
    edges = {}
    for rel, incs in graph.items():
        a = directory(rel)
        for kind, target in incs:
            if kind != "udvr":
                continue
            b = directory(target)
            if a and b and a != b:
                edges.setdefault(a, {}).setdefault(b, "%s -> %s" % (rel, target))
    cycles = []
    # Strongly connected components (Tarjan); a component of more than one directory is a cycle.
    index, low, on, stack, counter = {}, {}, set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in edges.get(v, {}):
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
                cycles.append(sorted(comp))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return cycles, edges


def main():
    src = pathlib.Path(sys.argv[1]) if len(sys.argv) > 1 else \
        pathlib.Path(__file__).resolve().parents[1] / "src"
    graph = scan(src)
    if not graph:
        print("check_layers: no sources under %s" % src, file=sys.stderr)
        return 2
    bad = 0
    for chain in core_violations(graph):
        print("core reaches a forbidden header: " + " -> ".join(chain))
        bad += 1
    for rel, target in plugin_violations(src.parent):
        print("the ParaView plugin includes a header above the core: %s -> %s" % (rel, target))
        bad += 1
    for rel, target in netcdf_violations(graph):
        print("netCDF-C/HDF5 called outside the files that hold netcdfLibraryMutex: %s includes "
              "<%s> (only %s may)" % (rel, target, ", ".join(NETCDF_FILES)))
        bad += 1
    for rel, number, what in simd_violations(src):
        print("SIMD outside util/lanes.h: %s:%d uses %s (intrinsics and vector types belong in "
              "util/lanes.h, the one SIMD vocabulary)" % (rel, number, what))
        bad += 1
    cycles, edges = directory_cycles(graph)
    for comp in cycles:
        print("directory cycle among %s:" % ", ".join(comp))
        for a in comp:
            for b in comp:
                if b in edges.get(a, {}):
                    print("    " + edges[a][b])
        bad += 1
    if bad:
        print("check_layers: %d violation(s) in %d files" % (bad, len(graph)))
        return 1
    print("check_layers: %d files; the core (%s) reaches no io/eval/cmd/serve or foreign header; "
          "no directory cycle; paraview/ includes only the core; netCDF-C/HDF5 only in io/netcdf_*; "
          "intrinsics and vector types only in util/lanes.h" % (len(graph), ", ".join(CORE)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
