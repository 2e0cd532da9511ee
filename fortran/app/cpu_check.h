/* cpu_check.h: the start-up check of the CPU's instruction set (cpu_check.c). */
#ifndef DC_CPU_CHECK_H
#define DC_CPU_CHECK_H
#include <stddef.h>

/* Exit status of a CPU that lacks what the build uses: 4, the environment the run cannot
 * proceed in (docs/scenes.md, Exit codes), as the Python package's DyncontactError. */
#define DC_EXIT_CPU 4

/* The number of features of x86-64-v3 that the check asks for (FMA is not one). */
#define DC_V3_FEATURES 15

/* Their names, as __builtin_cpu_supports spells them. */
extern const char *const dc_v3_features[DC_V3_FEATURES];

/* The number of features that the instruction set isa ("x86-64-v3" or "x86-64") uses and
 * a CPU lacks, given have[i] != 0 for each feature dc_v3_features[i] it has; msg (len
 * bytes) receives the one-line error (empty when nothing lacks). -1 when len is 0. */
int dc_cpu_lacking(const char *isa, const int have[DC_V3_FEATURES], char *msg, size_t len);

#endif
