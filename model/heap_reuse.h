// Keeps the memory a torch workload frees inside the process for its next
// iteration instead of handing it back to the kernel.
//
// glibc serves blocks above a moving threshold with mmap and gives the top
// of the heap back once 128 KiB are free there; a training step allocates
// and frees the same tens of megabytes every iteration, so with the paper's
// loss forms every iteration faulted its pages in again: about 50,000 page
// faults an iteration, and 40 iterations took 2.6 times as long
// (docs/PERFORMANCE.md).
//
// Thread safety: call once at the start of main, before other threads.
#pragma once

namespace mm {

// Fixes the mmap threshold at glibc's maximum (32 MiB), never trims the heap
// below 2 GiB of free memory and grows it 256 MiB at a time. The resident
// size then stays at the run's peak. No effect without glibc.
void keep_freed_memory_for_reuse();

}  // namespace mm
