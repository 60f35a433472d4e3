"""Pin the numeric libraries to one x86-64 level (x86-64-v3: AVX2 and FMA, Haswell and later) so that a seeded race
gives the same bits on every host.

numpy dispatches its transcendental functions and reductions to the widest SIMD the CPU has, OpenBLAS picks its
kernels by CPU, and numba compiles for the host's CPU: on a host with AVX-512 the last bits of ``np.sin`` or a
matrix product differ from an AVX2 host's, and a race (a chaotic system) diverges from the same seed. The race
digest, the bit-for-bit tests and a published race's replay assume one answer. This sets, unless already set,
``NPY_DISABLE_CPU_FEATURES`` (numpy's dispatch above AVX2), ``OPENBLAS_CORETYPE=Haswell`` and
``NUMBA_CPU_NAME=haswell``; each is read once, when its library loads, so this must run before numpy, scipy and
numba are imported (every package's ``__init__`` imports it first). Set a variable yourself to choose otherwise
(for instance ``NUMBA_CPU_NAME=host``).
"""

from __future__ import annotations

import os
import sys

NUMPY_ABOVE_AVX2 = "X86_V4 AVX512_ICL AVX512_SPR"
TARGET = {"OPENBLAS_CORETYPE": "Haswell", "NUMBA_CPU_NAME": "haswell"}


def configure() -> None:
    """Set the variables of the libraries not yet loaded in this process (and the processes it starts)."""
    if "numpy" not in sys.modules:
        os.environ.setdefault("NPY_DISABLE_CPU_FEATURES", NUMPY_ABOVE_AVX2)
        os.environ.setdefault("OPENBLAS_CORETYPE", TARGET["OPENBLAS_CORETYPE"])
    if "numba" not in sys.modules:
        os.environ.setdefault("NUMBA_CPU_NAME", TARGET["NUMBA_CPU_NAME"])


configure()
