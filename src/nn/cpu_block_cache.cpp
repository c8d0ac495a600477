#include "nn/cpu_block_cache.h"

#include <c10/core/Allocator.h>
#include <c10/core/CPUAllocator.h>
#include <c10/util/Exception.h>

#include <atomic>
#include <cstdlib>
#include <cstring>
#include <map>
#include <mutex>
#include <unordered_map>

namespace mosyn::nn {
namespace {

constexpr std::size_t kGranule = std::size_t{64} << 10;  // sizes rounded up to 64 KiB
constexpr std::size_t kAlignment = 64;                    // as c10's own CPU allocator

// allocate() is declared both const (LibTorch <= 2.2) and non-const (2.3 and later made the base
// one non-const and added copy_data), without `override`, so either base class is satisfied.
class BlockCache final : public c10::Allocator {
 public:
  explicit BlockCache(c10::Allocator* fallback) : fallback_(fallback) {}

  c10::DataPtr allocate(std::size_t bytes) const { return const_cast<BlockCache*>(this)->allocate_block(bytes); }
  c10::DataPtr allocate(std::size_t bytes) { return allocate_block(bytes); }
  void copy_data(void* dest, const void* src, std::size_t count) const { std::memcpy(dest, src, count); }

  CpuBlockCacheStats stats() {
    std::lock_guard<std::mutex> lock(mutex_);
    return stats_;
  }

  void release() {
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto& [size, block] : free_) std::free(block);
    free_.clear();
    stats_.cached_bytes = 0;
  }

 private:
  c10::DataPtr allocate_block(std::size_t bytes) {
    if (bytes < kMinCachedBytes) return fallback_->allocate(bytes);
    const std::size_t size = (bytes + kGranule - 1) / kGranule * kGranule;
    void* block = take_free(size);
    if (!block) block = system_allocate(size);
    return {block, block, &BlockCache::give_back, c10::Device(c10::DeviceType::CPU)};
  }

  // A free block of at least `size` bytes and at most 1/8 more, or nullptr.
  void* take_free(std::size_t size) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = free_.lower_bound(size);
    if (it == free_.end() || it->first > size + size / 8) return nullptr;
    void* block = it->second;
    live_[block] = it->first;
    stats_.cached_bytes -= it->first;
    stats_.live_bytes += it->first;
    ++stats_.reuses;
    free_.erase(it);
    return block;
  }

  void* system_allocate(std::size_t size) {
    void* block = nullptr;
    if (posix_memalign(&block, kAlignment, size) != 0) {
      release();  // the cache may hold what the system lacks
      if (posix_memalign(&block, kAlignment, size) != 0)
        TORCH_CHECK(false, "out of memory: could not allocate ", size, " bytes on the CPU");
    }
    std::lock_guard<std::mutex> lock(mutex_);
    live_[block] = size;
    stats_.live_bytes += size;
    ++stats_.system_allocations;
    return block;
  }

  static void give_back(void* block);

  c10::Allocator* fallback_;
  std::mutex mutex_;
  std::multimap<std::size_t, void*> free_;     // size in bytes -> free block
  std::unordered_map<void*, std::size_t> live_;  // block in use -> size in bytes
  CpuBlockCacheStats stats_;

  friend void release_to(BlockCache&, void*);
};

// Never destroyed: tensors freed during static destruction still find their cache.
std::atomic<BlockCache*> g_cache{nullptr};
std::once_flag g_install_once;

void release_to(BlockCache& cache, void* block) {
  std::lock_guard<std::mutex> lock(cache.mutex_);
  auto it = cache.live_.find(block);
  if (it == cache.live_.end()) return;  // not ours: cannot happen, but never free a stranger's block
  const std::size_t size = it->second;
  cache.live_.erase(it);
  cache.stats_.live_bytes -= size;
  if (cache.stats_.cached_bytes + size > kMaxCachedBytes) {
    std::free(block);
    return;
  }
  cache.free_.emplace(size, block);
  cache.stats_.cached_bytes += size;
}

void BlockCache::give_back(void* block) { release_to(*g_cache.load(), block); }

}  // namespace

void use_cpu_block_cache() {
  std::call_once(g_install_once, [] {
    auto* cache = new BlockCache(c10::GetCPUAllocator());
    g_cache.store(cache);
    c10::SetCPUAllocator(cache, /*priority=*/1);
  });
}

bool cpu_block_cache_installed() { return g_cache != nullptr; }

CpuBlockCacheStats cpu_block_cache_stats() {
  BlockCache* cache = g_cache.load();
  return cache ? cache->stats() : CpuBlockCacheStats{};
}

void release_cpu_block_cache() {
  if (BlockCache* cache = g_cache.load()) cache->release();
}

}  // namespace mosyn::nn
