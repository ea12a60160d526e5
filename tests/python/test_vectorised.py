"""The loops the native code marks `#pragma omp simd` (the batch loops that run
a contact law's lane functions for pairs and walls, the curved wall's contact
geometry) are vectorised by the compiler, for every law the drum runs in SIMD
lanes, with AVX2 and with AVX-512.

GCC keeps such a loop scalar when it cannot make it branch-free (a division
under a condition, say: "control flow in loop" without AVX-512's masked
lanes), and says so only in its optimisation report. The forces stay right,
so no physics test fails; the drum's pair loop ran 1.5 times slower per
contact on an AVX2 machine until the kernels were written without it
(docs/speed_accuracy.md). This test compiles tests/native/vectorised_kernels.cpp
once per kernel and instruction set and reads GCC's report
(-fopt-info-vec-optimized) for that kernel's loop.
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
FLAGS = ["-std=c++17", "-O3", "-DNDEBUG", "-fno-math-errno", "-ffp-contract=off", "-fopenmp"]
TARGETS = {"AVX2": "-march=haswell", "AVX-512": "-march=skylake-avx512"}
# KERNEL in vectorised_kernels.cpp -> (what it is, the header of its loop,
# which of the header's omp simd loops it is, counted from 0).
KERNELS = {
    1: ("linear law, pairs, 2D", "contact/pair_batch.hpp", 0),
    2: ("linear law, pairs, 3D", "contact/pair_batch.hpp", 0),
    3: ("Rapaport law, pairs, 2D", "contact/pair_batch.hpp", 0),
    4: ("Rapaport law, pairs, 3D", "contact/pair_batch.hpp", 0),
    5: ("linear law, walls, 3D", "contact/wall_batch.hpp", 0),
    6: ("Rapaport law, walls, 3D", "contact/wall_batch.hpp", 0),
    7: ("curved wall, contact geometry", "boundary/cylinder_wall.hpp", 0),
}


def compiler():
    cxx = os.environ.get("GRANULAR_CXX") or shutil.which("g++")
    if not cxx:
        pytest.skip("no C++ compiler")
    version = subprocess.run([cxx, "--version"], capture_output=True, text=True).stdout
    if "Free Software Foundation" not in version:
        pytest.skip(f"{cxx} is not GCC: its optimisation report has another form")
    return cxx


def simd_pragmas():
    """{header relative to native/src: [1-based lines of its omp simd pragmas]}."""
    found = {}
    for path in sorted(SRC.rglob("*.hpp")):
        for k, line in enumerate(path.read_text().splitlines()):
            if line.strip().startswith("#pragma omp simd"):
                found.setdefault(path.relative_to(SRC).as_posix(), []).append(k + 1)
    return found


def test_every_simd_loop_has_a_kernel():
    """A new `omp simd` loop needs a KERNEL here, or this test would not see it."""
    pragmas = simd_pragmas()
    loops = {(h, k) for h, lines in pragmas.items() for k in range(len(lines))}
    assert loops == {(h, k) for _, h, k in KERNELS.values()}, pragmas


@pytest.mark.parametrize("isa", sorted(TARGETS))
@pytest.mark.parametrize("kernel", sorted(KERNELS))
def test_the_kernel_is_vectorised(kernel, isa, tmp_path):
    cxx = compiler()
    what, header, index = KERNELS[kernel]
    cmd = [cxx, *FLAGS, TARGETS[isa], f"-DKERNEL={kernel}", f"-I{SRC}", "-isystem", "/usr/include/eigen3",
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
    pragma = simd_pragmas()[header][index]
    assert any((header, pragma + d) in done for d in range(1, 5)), (
        f"{isa}, {what}: the loop under '#pragma omp simd' at {header}:{pragma} was left scalar; "
        f"the compiler vectorised {sorted(done)}. Compile with -fopt-info-vec-missed to see why."
    )
