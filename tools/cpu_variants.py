"""Two CPUs on one machine: the environments that make and that check the book's committed outputs.

The last bits of a floating-point sum depend on the CPU: OpenBLAS picks its kernels by CPU model, NumPy its SIMD
loops by CPU feature, glibc its libm variants (with or without FMA) by CPU feature. A notebook output that shows
those bits passes on the machine that committed it and fails on the next one (an AMD machine against an Intel
one, issue 21). All three choices can be forced from the environment, so one machine can play two CPUs:

* ``MAKE`` -- how ``make notebooks`` runs the kernels that write the committed outputs: OpenBLAS's Haswell
  kernels and NumPy without AVX-512 (what an AMD Zen 2/3 machine runs natively);
* ``CHECK`` -- how ``make test`` runs the kernels whose outputs nbval compares with the committed ones: OpenBLAS's
  Sandybridge kernels, NumPy's baseline loops (no AVX2, no AVX-512), glibc's libm without FMA or AVX2.

Every nbval run of ``make test`` is therefore a comparison across two CPUs, on any x86-64 machine with AVX2: an
output that depends on the CPU fails it here, not on someone else's machine later. Setting
``UWTUTOR_NATIVE_CPU=1`` runs the kernels with the machine's own choices instead (to reproduce a report).

Both environments only restrict a machine to what every x86-64 machine with AVX2 has; on other CPUs the variables
are ignored (OpenBLAS and NumPy fall back to what the machine supports).
"""

from __future__ import annotations

import os

#: What ``make notebooks`` writes the committed outputs with.
MAKE: dict[str, str] = {
    "OPENBLAS_CORETYPE": "Haswell",
    "NPY_DISABLE_CPU_FEATURES": "X86_V4 AVX512_ICL AVX512_SPR",
}

#: What ``make test`` checks them with (nbval's kernels and the other subprocesses of the tests).
CHECK: dict[str, str] = {
    "OPENBLAS_CORETYPE": "Sandybridge",
    "NPY_DISABLE_CPU_FEATURES": "X86_V3 X86_V4 AVX512_ICL AVX512_SPR",
    "GLIBC_TUNABLES": "glibc.cpu.hwcaps=-AVX2,-FMA,-AVX512F",
}


def kernel_env(variant: dict[str, str]) -> dict[str, str]:
    """The environment of a kernel started now: this process's, with ``variant`` applied (unless native)."""
    env = dict(os.environ)
    if os.environ.get("UWTUTOR_NATIVE_CPU", "") not in ("", "0"):
        return env
    env.update(variant)
    return env
