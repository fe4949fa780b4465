// The evaluation loop of mjfx_evaluate for 4 lanes, compiled for AVX (see elements.h): the same
// source as the 2-lane loop (evaluate.h), wider vectors. mjfx_evaluate runs it where the CPU has
// AVX. No FMA: the target adds AVX only, and -ffp-contract=off keeps every product rounded, so
// each lane computes exactly what the 2-lane build computes.

#include "elements.h"

#if MJFX_HAVE_AVX_BUILD
#pragma GCC target("avx")
#define MJFX_LANES 4
#define MJFX_EVALUATE mjfx_evaluate_lanes4
#include "evaluate.h"
#else
typedef int mjfx_no_avx_build;  // an empty translation unit is not ISO C
#endif
