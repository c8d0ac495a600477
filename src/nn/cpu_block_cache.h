// A caching CPU allocator for LibTorch's large tensors.
//
// Why: a training step allocates and frees the same large activations (MoGlow at the paper's size:
// [50 frames, 100 windows, 2048 gates] floats, 41 MB, dozens per coupling) every step. glibc serves
// blocks above its mmap threshold (at most 32 MiB) with fresh mmap()s, and every page of those is
// faulted in and zeroed by the kernel on first touch: a quarter to a third of a paper-size MoGlow
// step on this machine (perf: page faults and clear_page). Keeping freed large blocks for reuse
// removes that cost, as LibTorch's CUDA caching allocator does on the GPU.
//
// Blocks of at least kMinCachedBytes are rounded up to 64 KiB and reused by any later request
// that they fit within 1/8 of their size; smaller ones are plain aligned allocations, freed at
// once. Every block carries a 64-byte size header, so one deleter serves all (oneDNN's
// raw_allocate/raw_deallocate need that). At most kMaxCachedBytes of free blocks are kept; beyond that, freed blocks return to the system.
// Thread-safe. The values in a reused block are whatever its last tensor left (LibTorch never
// assumes fresh memory is zeroed: torch::empty semantics).
#pragma once

#include <cstddef>
#include <cstdint>

namespace mosyn::nn {

inline constexpr std::size_t kMinCachedBytes = std::size_t{1} << 20;    // 1 MiB
inline constexpr std::size_t kMaxCachedBytes = std::size_t{4} << 30;    // 4 GiB of free blocks

// Installs the cache as LibTorch's CPU allocator for the rest of the process. Idempotent and
// thread-safe; tensors allocated before keep their own deleters. The trainer calls it; a program
// that trains or evaluates models directly may call it at start-up.
void use_cpu_block_cache();

// True once use_cpu_block_cache() has run.
bool cpu_block_cache_installed();

// Counters since installation (for tests and benchmarks).
struct CpuBlockCacheStats {
  std::int64_t system_allocations = 0;  // large blocks obtained from the system
  std::int64_t reuses = 0;              // large requests served from the cache
  std::size_t cached_bytes = 0;         // free blocks held now
  std::size_t live_bytes = 0;           // large blocks in use now
};
CpuBlockCacheStats cpu_block_cache_stats();

// Returns every free block to the system (live blocks are untouched).
void release_cpu_block_cache();

}  // namespace mosyn::nn
