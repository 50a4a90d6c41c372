"""scripts/check_layers.py (run by CTest as Layers.IncludeGraph) on small made-up source trees:
each rule flags what it forbids, with the file and line, and passes what it allows."""
import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "scripts" / "check_layers.py"


def check(tmp_path, files):
    """Writes files ({path under the repository: text}) and runs the check on tmp_path/src."""
    for rel, text in files.items():
        path = tmp_path / rel
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return subprocess.run([sys.executable, str(SCRIPT), str(tmp_path / "src")],
                          capture_output=True, text=True, timeout=60)


LANES = """#pragma once
#include <immintrin.h>
typedef float Vf __attribute__((vector_size(64)));
inline Vf loadHalves(const float* lo, const float* hi) { return _mm512_castpd_ps(__m512d{}); }
"""


def test_the_repository_passes():
    r = subprocess.run([sys.executable, str(SCRIPT)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr


def test_intrinsics_and_vector_types_only_in_lanes_h(tmp_path):
    r = check(tmp_path, {
        "src/udvr/util/lanes.h": LANES,
        "src/udvr/util/lanes_test.cpp": "#include <immintrin.h>\n__m256 a = _mm256_setzero_ps();\n",
        "src/udvr/reconstruct/rows.h": (
            '#pragma once\n#include "udvr/util/lanes.h"\n'
            "// _mm512_insertf64x4 in a comment, and /* __m256 */ in a block one\n"
            'const char* kName = "_mm256_loadu_ps";\n'
            "inline Vf f(const float* p) {\n"
            "    const __m256 a = _mm256_loadu_ps(p);\n"  # line 6: two uses
            "    return loadHalves(p, p + 8);\n}\n"),
        "src/udvr/stats/em.cpp": "using D4 = double __attribute__((vector_size(32)));\n",
        "src/udvr/util/neon.h": "#pragma once\n#include <arm_neon.h>\nfloat32x4_t g();\n",
        "bench/x_bench.cpp": "#include <x86intrin.h>\n",
    })
    assert r.returncode == 1, r.stdout
    bad = sorted(line.split(": ", 1)[1].split(" (")[0]
                 for line in r.stdout.splitlines() if line.startswith("SIMD outside"))
    assert bad == sorted([
        "udvr/reconstruct/rows.h:6 uses __m256",
        "udvr/reconstruct/rows.h:6 uses _mm256_loadu_ps",
        "udvr/stats/em.cpp:1 uses vector_size",
        "udvr/util/neon.h:2 uses <arm_neon.h>",
        "udvr/util/neon.h:3 uses float32x4_t",
        "bench/x_bench.cpp:1 uses <x86intrin.h>",
    ]), r.stdout
    assert "check_layers: 6 violation(s)" in r.stdout


def test_lanes_vocabulary_outside_lanes_h_passes(tmp_path):
    r = check(tmp_path, {
        "src/udvr/util/lanes.h": LANES,
        "src/udvr/reconstruct/rows.h": ('#pragma once\n#include "udvr/util/lanes.h"\n'
                                        "inline Vf f(const float* p) { return loadHalves(p, p); }\n"),
    })
    assert r.returncode == 0, r.stdout


def test_core_reaching_io_and_directory_cycles_fail(tmp_path):
    r = check(tmp_path, {
        "src/udvr/render/a.h": '#pragma once\n#include "udvr/io/b.h"\n',
        "src/udvr/io/b.h": '#pragma once\n#include "udvr/render/c.h"\n',
        "src/udvr/render/c.h": "#pragma once\n",
    })
    assert r.returncode == 1, r.stdout
    assert "core reaches a forbidden header: udvr/render/a.h -> udvr/io/b.h" in r.stdout
    assert "directory cycle among io, render" in r.stdout


def test_relative_includes_and_register_shuffles_are_seen(tmp_path):
    # A quoted include beside the file ("../io/b.h") is followed like "udvr/io/b.h"; a register
    # shuffle by __builtin_shufflevector or an __builtin_ia32_* builtin is per-ISA SIMD.
    r = check(tmp_path, {
        "src/udvr/util/lanes.h": LANES,
        "src/udvr/util/sneaky.h": '#pragma once\n#include "../io/b.h"\n',
        "src/udvr/io/b.h": '#pragma once\n#include <vtkImageData.h>\n',
        "src/udvr/reconstruct/rows.h": (
            '#pragma once\n#include "udvr/util/lanes.h"\n'
            "inline Vf f(Vf v) { return __builtin_shufflevector(v, v, 1, 0); }\n"
            "inline Vf g(Vf v) { return __builtin_ia32_sqrtps512(v); }\n"),
        "src/udvr/render/ok.h": '#pragma once\n#include "missing_beside.h"\n',
    })
    assert r.returncode == 1, r.stdout
    assert "core reaches a forbidden header: udvr/util/sneaky.h -> udvr/io/b.h" in r.stdout
    bad = sorted(line.split(": ", 1)[1].split(" (")[0]
                 for line in r.stdout.splitlines() if line.startswith("SIMD outside"))
    assert bad == ["udvr/reconstruct/rows.h:3 uses __builtin_shufflevector",
                   "udvr/reconstruct/rows.h:4 uses __builtin_ia32_sqrtps512"], r.stdout
    assert "render/ok.h" not in r.stdout
