// MM_VECTOR_CLONES before a function with a hot loop compiles it once for
// each vector width x86-64 CPUs have (AVX-512, AVX2, baseline) and picks the
// clone when the program loads: the build targets every x86-64 CPU, while
// the loop wants the widest registers of the one it runs on. Elsewhere (other
// compilers or processors) it is one ordinary function.
#pragma once

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
#define MM_VECTOR_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#else
#define MM_VECTOR_CLONES
#endif
