/* The start-up check's message (fortran/app/cpu_check.c) for made-up CPUs: one with all of
 * x86-64-v3, one without AVX2 and BMI2, one of the baseline only; and the portable build,
 * which asks for nothing. Exits 1 on the first failed check. */
#include <stdio.h>
#include <string.h>

#include "cpu_check.h"

static int failed = 0;

static void check(int ok, const char *what, const char *msg)
{
    if (!ok) {
        printf("FAILED: %s (message: %s)\n", what, msg);
        failed = 1;
    }
}

static int index_of(const char *name)
{
    for (int i = 0; i < DC_V3_FEATURES; i++)
        if (strcmp(dc_v3_features[i], name) == 0) return i;
    return -1;
}

int main(void)
{
    int have[DC_V3_FEATURES];
    char msg[512];
    int n;

    for (int i = 0; i < DC_V3_FEATURES; i++) have[i] = 1;
    n = dc_cpu_lacking("x86-64-v3", have, msg, sizeof msg);
    check(n == 0 && msg[0] == '\0', "a v3 CPU lacks nothing", msg);

    check(index_of("avx2") >= 0 && index_of("bmi2") >= 0, "avx2 and bmi2 are checked", "");
    check(index_of("fma") < 0, "fma is not checked (the build uses -mno-fma)", "");
    have[index_of("avx2")] = 0;
    have[index_of("bmi2")] = 0;
    n = dc_cpu_lacking("x86-64-v3", have, msg, sizeof msg);
    check(n == 2, "two features lacking", msg);
    check(strstr(msg, "dyncontact: ") == msg, "the program's prefix", msg);
    check(strstr(msg, "x86-64-v3") != NULL, "names what the build uses", msg);
    check(strstr(msg, "lacks avx2, bmi2;") != NULL, "names what the CPU lacks", msg);
    check(strstr(msg, "-Dsimd=portable") != NULL, "names the fix", msg);
    check(strchr(msg, '\n') == NULL, "one line", msg);

    n = dc_cpu_lacking("x86-64", have, msg, sizeof msg);
    check(n == 0 && msg[0] == '\0', "the portable build needs nothing", msg);

    /* a CPU of the x86-64 baseline only (SSE2): everything of the list lacks */
    for (int i = 0; i < DC_V3_FEATURES; i++) have[i] = 0;
    n = dc_cpu_lacking("x86-64-v3", have, msg, sizeof msg);
    check(n == DC_V3_FEATURES, "a baseline CPU lacks all", msg);
    check(strstr(msg, "-Dsimd=portable") != NULL, "the fix fits in the line", msg);

    /* a short buffer is cut, never overrun */
    n = dc_cpu_lacking("x86-64-v3", have, msg, 16);
    check(n == DC_V3_FEATURES && strlen(msg) == 15, "a short buffer is cut", msg);

    check(DC_EXIT_CPU == 4, "exit status 4", "");
    if (!failed) printf("cpu_check: all checks passed\n");
    return failed;
}
