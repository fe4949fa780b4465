// The evaluation loop of mjfx_evaluate for the base build's lanes (see elements.h): 2 with GNU C (SSE2 on
// x86-64, any such CPU), else 1; the source is evaluate.h, which evaluate_avx.c builds for 4 lanes too.

#include "elements.h"

#define MJFX_EVALUATE mjfx_evaluate_base
#include "evaluate.h"
