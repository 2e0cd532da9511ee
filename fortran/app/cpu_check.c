/* cpu_check.c: the executable's start-up check that the CPU has the instructions the core
 * was compiled for.
 *
 * A build with -Dsimd=auto on a machine with x86-64-v3 compiles the core with
 * -march=x86-64-v3 (meson.build). On an older CPU (a cluster's compute node older than the
 * node that built it) its first AVX2 instruction kills the program with SIGILL, "Illegal
 * instruction", and no word on why. The constructor below runs before main (before any
 * code of the core, the Fortran runtime's initialization of main included) and stops with
 * one line and exit status 4 (an environment the run cannot proceed in, as out of memory:
 * the scene is not at fault, so not 2) saying what the build needs, what the CPU lacks
 * and how to rebuild.
 *
 * This file is compiled for the baseline x86-64 whatever the simd option (its c_args in the
 * top-level meson.build come after the project's -march=x86-64-v3, and the last -march
 * wins; tests/test_cpu_check.py checks the compile command), so the check itself runs on
 * any x86-64 CPU. The constructor is compiled only where DC_CPU_CHECK_ISA names the level
 * the core was built for (x86-64-v3 builds); the message is made by dc_cpu_lacking(),
 * which takes the CPU's features as input, so that a test can give it a CPU without AVX2
 * (tests/c/test_cpu_check.c) without old hardware and without a switch in the program. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cpu_check.h"

/* The features of x86-64-v3 (the x86-64 psABI's levels v2 and v3) but FMA, which the build
 * leaves out (-mno-fma), by the names of GCC's __builtin_cpu_supports;
 * python/dyncontact/core.py has the same list with the flag names of /proc/cpuinfo. */
const char *const dc_v3_features[DC_V3_FEATURES] = {
    "cmpxchg16b", "lahf_lm", "popcnt", "sse3", "sse4.1", "sse4.2", "ssse3",
    "avx", "avx2", "bmi", "bmi2", "f16c", "lzcnt", "movbe", "osxsave"};

int dc_cpu_lacking(const char *isa, const int have[DC_V3_FEATURES], char *msg, size_t len)
{
    int missing = 0;
    size_t used;
    if (len == 0) return -1;
    msg[0] = '\0';
    if (strcmp(isa, "x86-64-v3") != 0) return 0;   /* the baseline needs nothing */
    used = (size_t)snprintf(msg, len, "dyncontact: this build of the core uses x86-64-v3 "
                            "instructions (AVX2; -Dsimd=auto on a machine that has them) "
                            "and this CPU lacks");
    for (int i = 0; i < DC_V3_FEATURES; i++) {
        if (have[i]) continue;
        missing++;
        if (used < len)
            used += (size_t)snprintf(msg + used, len - used, "%s %s",
                                     missing == 1 ? "" : ",", dc_v3_features[i]);
    }
    if (missing == 0) {
        msg[0] = '\0';
        return 0;
    }
    if (used < len)
        snprintf(msg + used, len - used, "; rebuild with `meson setup build -Dsimd=portable`"
                 " (or `pip install . -Csetup-args=-Dsimd=portable`)");
    return missing;
}

#ifdef DC_CPU_CHECK_ISA
/* __builtin_cpu_supports takes a string literal only, hence one line a feature, in the
 * order of dc_v3_features. */
__attribute__((constructor)) static void dc_cpu_check(void)
{
    int have[DC_V3_FEATURES];
    char msg[512];
    __builtin_cpu_init();
    have[0] = __builtin_cpu_supports("cmpxchg16b");
    have[1] = __builtin_cpu_supports("lahf_lm");
    have[2] = __builtin_cpu_supports("popcnt");
    have[3] = __builtin_cpu_supports("sse3");
    have[4] = __builtin_cpu_supports("sse4.1");
    have[5] = __builtin_cpu_supports("sse4.2");
    have[6] = __builtin_cpu_supports("ssse3");
    have[7] = __builtin_cpu_supports("avx");
    have[8] = __builtin_cpu_supports("avx2");
    have[9] = __builtin_cpu_supports("bmi");
    have[10] = __builtin_cpu_supports("bmi2");
    have[11] = __builtin_cpu_supports("f16c");
    have[12] = __builtin_cpu_supports("lzcnt");
    have[13] = __builtin_cpu_supports("movbe");
    have[14] = __builtin_cpu_supports("osxsave");
    if (dc_cpu_lacking(DC_CPU_CHECK_ISA, have, msg, sizeof msg) > 0) {
        fprintf(stderr, "%s\n", msg);
        exit(DC_EXIT_CPU);
    }
}
#endif
