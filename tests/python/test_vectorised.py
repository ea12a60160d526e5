"""Every loop the native code marks `#pragma omp simd` (the contact laws'
batch kernels) is vectorised by the compiler, with AVX2 and with AVX-512.

GCC keeps such a loop scalar when it cannot make it branch-free (a division
under a condition, say, "control flow in loop" without AVX-512's masked
lanes), and says so only in its optimisation report. The forces stay right,
so no physics test fails; the drum's pair loop ran 1.5 times slower per
contact on an AVX2 machine until the kernels were written without it
(docs/speed_accuracy.md). This test compiles tests/native/vectorised_kernels.cpp,
which instantiates every batch kernel, for both instruction sets and reads
GCC's report (-fopt-info-vec-optimized).
"""

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SRC = ROOT / "native" / "src"
TU = ROOT / "tests" / "native" / "vectorised_kernels.cpp"
# The flags of the release build (native/CMakeLists.txt) that bear on
# vectorisation; the instruction set is the test's.
FLAGS = ["-std=c++17", "-O3", "-DNDEBUG", "-fno-math-errno", "-fopenmp"]
TARGETS = {"AVX2": "-march=haswell", "AVX-512": "-march=skylake-avx512"}


def compiler():
    cxx = os.environ.get("GRANULAR_CXX") or shutil.which("g++")
    if not cxx:
        pytest.skip("no C++ compiler")
    version = subprocess.run([cxx, "--version"], capture_output=True, text=True).stdout
    if "g++" not in version and "GCC" not in version and "Free Software Foundation" not in version:
        pytest.skip(f"{cxx} is not GCC: its optimisation report has another form")
    return cxx


def simd_loops():
    """(header relative to native/src, line of the pragma) of each omp simd pragma."""
    loops = []
    for path in sorted(SRC.rglob("*.hpp")):
        lines = path.read_text().splitlines()
        for k, line in enumerate(lines):
            if line.strip().startswith("#pragma omp simd"):
                loops.append((path.relative_to(SRC).as_posix(), k + 1))
    return loops


def test_the_kernels_are_found():
    loops = simd_loops()
    names = {f for f, _ in loops}
    assert {"contact/linear.hpp", "contact/rapaport.hpp"} <= names, loops


@pytest.mark.parametrize("isa", sorted(TARGETS))
def test_every_simd_loop_is_vectorised(isa, tmp_path):
    cxx = compiler()
    cmd = [cxx, *FLAGS, TARGETS[isa], f"-I{SRC}", "-isystem", "/usr/include/eigen3",
           "-fopt-info-vec-optimized", "-c", str(TU), "-o", str(tmp_path / "k.o")]
    run = subprocess.run(cmd, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-2000:]
    done = set()
    for m in re.finditer(r"([\w/.-]+\.hpp):(\d+):\d+: optimized: loop vectorized", run.stderr):
        path = Path(m.group(1))
        rel = path.resolve().relative_to(SRC.resolve()).as_posix() if path.is_absolute() else m.group(1)
        done.add((rel, int(m.group(2))))
    # GCC names a loop by its first statement: the line after the `for`,
    # which follows the pragma (a few lines on, should the `for` wrap).
    missed = [(f, k) for f, k in simd_loops() if not any((f, k + d) in done for d in range(1, 5))]
    assert not missed, (
        f"{isa}: loops under '#pragma omp simd' left scalar (header, line of the pragma): {missed}; "
        f"the compiler vectorised {sorted(done)}. Compile with -fopt-info-vec-missed to see why."
    )
