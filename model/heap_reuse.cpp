#include "model/heap_reuse.h"

#include <climits>  // also defines __GLIBC__ where glibc is the C library

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace mm {

void keep_freed_memory_for_reuse() {
#if defined(__GLIBC__)
  // Setting the threshold explicitly also stops glibc's dynamic adjustment.
  mallopt(M_MMAP_THRESHOLD, 32 * 1024 * 1024);
  mallopt(M_TRIM_THRESHOLD, INT_MAX);  // mallopt takes an int: 2 GiB
  mallopt(M_TOP_PAD, 256 * 1024 * 1024);
#endif
}

}  // namespace mm
