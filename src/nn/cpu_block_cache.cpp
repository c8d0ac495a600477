#include "nn/cpu_block_cache.h"

#include <c10/core/Allocator.h>
#include <c10/core/CPUAllocator.h>
#include <c10/util/Exception.h>

#include <atomic>
#include <cstdlib>
#include <cstring>
#include <map>
#include <mutex>

namespace mosyn::nn {
namespace {

constexpr std::size_t kGranule = std::size_t{64} << 10;  // large sizes rounded up to 64 KiB
constexpr std::size_t kAlignment = 64;                    // as c10's own CPU allocator
// Every block starts with a header of kAlignment bytes holding its size, so one deleter frees
// small and large blocks alike and data == context: oneDNN (mkldnn convolutions) allocates through
// Allocator::raw_allocate / raw_deallocate, which need raw_deleter() and that identity.
constexpr std::size_t kHeader = kAlignment;

struct Header {
  std::size_t bytes;  // usable bytes after the header (large blocks: rounded up)
};

void* data_of(void* base) { return static_cast<char*>(base) + kHeader; }
void* base_of(void* data) { return static_cast<char*>(data) - kHeader; }
std::size_t bytes_of(void* data) { return static_cast<Header*>(base_of(data))->bytes; }

// A block of kHeader + bytes from the system, its header written; nullptr when the system has none.
void* system_block(std::size_t bytes) {
  void* base = nullptr;
  if (posix_memalign(&base, kAlignment, kHeader + bytes) != 0) return nullptr;
  static_cast<Header*>(base)->bytes = bytes;
  return data_of(base);
}

// allocate() is declared both const (LibTorch <= 2.2) and non-const (2.3 and later made the base
// one non-const and added copy_data), without `override`, so either base class is satisfied.
class BlockCache final : public c10::Allocator {
 public:
  c10::DataPtr allocate(std::size_t bytes) const { return const_cast<BlockCache*>(this)->allocate_block(bytes); }
  c10::DataPtr allocate(std::size_t bytes) { return allocate_block(bytes); }
  void copy_data(void* dest, const void* src, std::size_t count) const { std::memcpy(dest, src, count); }
  c10::DeleterFnPtr raw_deleter() const { return &BlockCache::give_back; }

  CpuBlockCacheStats stats() {
    std::lock_guard<std::mutex> lock(mutex_);
    return stats_;
  }

  void release() {
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto& [size, data] : free_) std::free(base_of(data));
    free_.clear();
    stats_.cached_bytes = 0;
  }

  void take_back(void* data);

 private:
  c10::DataPtr allocate_block(std::size_t bytes) {
    void* data = nullptr;
    if (bytes < kMinCachedBytes) {
      data = system_block(bytes);
      TORCH_CHECK(data != nullptr, "out of memory: could not allocate ", bytes, " bytes on the CPU");
    } else {
      const std::size_t size = (bytes + kGranule - 1) / kGranule * kGranule;
      data = take_free(size);
      if (!data) data = new_large(size);
    }
    return {data, data, &BlockCache::give_back, c10::Device(c10::DeviceType::CPU)};
  }

  // A free block of at least `size` bytes and at most 1/8 more, or nullptr.
  void* take_free(std::size_t size) {
    std::lock_guard<std::mutex> lock(mutex_);
    auto it = free_.lower_bound(size);
    if (it == free_.end() || it->first > size + size / 8) return nullptr;
    void* data = it->second;
    stats_.cached_bytes -= it->first;
    stats_.live_bytes += it->first;
    ++stats_.reuses;
    free_.erase(it);
    return data;
  }

  void* new_large(std::size_t size) {
    void* data = system_block(size);
    if (!data) {
      release();  // the cache may hold what the system lacks
      data = system_block(size);
      TORCH_CHECK(data != nullptr, "out of memory: could not allocate ", size, " bytes on the CPU");
    }
    std::lock_guard<std::mutex> lock(mutex_);
    stats_.live_bytes += size;
    ++stats_.system_allocations;
    return data;
  }

  static void give_back(void* data);

  std::mutex mutex_;
  std::multimap<std::size_t, void*> free_;  // size in bytes -> free block (its data pointer)
  CpuBlockCacheStats stats_;
};

// Never destroyed: tensors freed during static destruction still find their cache.
std::atomic<BlockCache*> g_cache{nullptr};
std::once_flag g_install_once;

void BlockCache::take_back(void* data) {
  const std::size_t size = bytes_of(data);
  if (size < kMinCachedBytes) {
    std::free(base_of(data));
    return;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  stats_.live_bytes -= size;
  if (stats_.cached_bytes + size > kMaxCachedBytes) {
    std::free(base_of(data));
    return;
  }
  free_.emplace(size, data);
  stats_.cached_bytes += size;
}

void BlockCache::give_back(void* data) {
  if (data) g_cache.load()->take_back(data);
}

}  // namespace

void use_cpu_block_cache() {
  std::call_once(g_install_once, [] {
    auto* cache = new BlockCache();
    g_cache.store(cache);
    c10::SetCPUAllocator(cache, /*priority=*/1);
  });
}

bool cpu_block_cache_installed() { return g_cache.load() != nullptr; }

CpuBlockCacheStats cpu_block_cache_stats() {
  BlockCache* cache = g_cache.load();
  return cache ? cache->stats() : CpuBlockCacheStats{};
}

void release_cpu_block_cache() {
  if (BlockCache* cache = g_cache.load()) cache->release();
}

}  // namespace mosyn::nn
