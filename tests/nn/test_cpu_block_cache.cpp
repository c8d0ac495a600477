// The CPU block cache (nn/cpu_block_cache.h): large tensors reuse freed blocks, small ones do not
// pass through it, values survive, limits hold, and concurrent use stays consistent.
#include <gtest/gtest.h>
#include <c10/core/CPUAllocator.h>
#include <torch/torch.h>

#include <cstring>
#include <thread>
#include <vector>

#include "nn/cpu_block_cache.h"

using namespace mosyn::nn;

namespace {

constexpr int64_t kLargeFloats = 3 * (1 << 20) / 4 + 5;  // 3 MiB + 20 bytes: rounded up to 64 KiB

TEST(CpuBlockCache, ReusesAFreedLargeBlock) {
  use_cpu_block_cache();
  use_cpu_block_cache();  // idempotent
  ASSERT_TRUE(cpu_block_cache_installed());
  release_cpu_block_cache();
  const auto before = cpu_block_cache_stats();
  void* first = nullptr;
  {
    auto t = torch::empty({kLargeFloats});
    first = t.data_ptr();
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(first) % 64, 0u);
    const auto live = cpu_block_cache_stats();
    EXPECT_EQ(live.system_allocations, before.system_allocations + 1);
    EXPECT_EQ(live.live_bytes, before.live_bytes + (3u << 20) + (64u << 10));  // rounded up to 64 KiB
  }
  const auto freed = cpu_block_cache_stats();
  EXPECT_EQ(freed.cached_bytes, (3u << 20) + (64u << 10));
  EXPECT_EQ(freed.live_bytes, before.live_bytes);
  // A slightly smaller request fits the same block (within 1/8); a much smaller large one does not.
  auto again = torch::empty({kLargeFloats - 1000});
  EXPECT_EQ(again.data_ptr(), first);
  EXPECT_EQ(cpu_block_cache_stats().reuses, before.reuses + 1);
  auto half = torch::empty({kLargeFloats / 2});
  EXPECT_NE(half.data_ptr(), first);
  EXPECT_EQ(cpu_block_cache_stats().system_allocations, before.system_allocations + 2);
}

TEST(CpuBlockCache, SmallTensorsBypassIt) {
  use_cpu_block_cache();
  const auto before = cpu_block_cache_stats();
  { auto t = torch::ones({1000}); EXPECT_EQ(t.sum().item<float>(), 1000.f); }
  const auto after = cpu_block_cache_stats();
  EXPECT_EQ(after.system_allocations, before.system_allocations);
  EXPECT_EQ(after.reuses, before.reuses);
  EXPECT_EQ(after.cached_bytes, before.cached_bytes);
}

TEST(CpuBlockCache, ValuesAndGradientsAreUnchanged) {
  use_cpu_block_cache();
  torch::manual_seed(3);
  // Large enough that every intermediate goes through the cache: matmul and its backward by hand.
  auto a = torch::randn({600, 500}, torch::requires_grad());
  auto b = torch::randn({500, 700});
  for (int round = 0; round < 3; ++round) {  // later rounds run on reused blocks
    auto y = torch::tanh(a.matmul(b));
    y.sum().backward();
    auto expected = (1 - y.detach().pow(2)).matmul(b.t());
    EXPECT_TRUE(torch::allclose(a.grad(), expected, 1e-5, 1e-5)) << "round " << round;
    a.mutable_grad().reset();
  }
  EXPECT_GT(cpu_block_cache_stats().reuses, 0);
}

// oneDNN (mkldnn convolutions) allocates through raw_allocate / raw_deallocate, which need one
// deleter for every block and data == context, small and large.
TEST(CpuBlockCache, RawAllocationsAndConvolutions) {
  use_cpu_block_cache();
  c10::Allocator* allocator = c10::GetCPUAllocator();
  ASSERT_NE(allocator->raw_deleter(), nullptr);
  for (size_t bytes : {size_t{16}, size_t{5000}, size_t{3} << 20}) {
    void* p = allocator->raw_allocate(bytes);
    ASSERT_NE(p, nullptr);
    EXPECT_EQ(reinterpret_cast<std::uintptr_t>(p) % 64, 0u);
    std::memset(p, 1, bytes);
    allocator->raw_deallocate(p);
  }
  torch::manual_seed(4);
  torch::nn::Conv1d conv(torch::nn::Conv1dOptions(8, 16, 5).padding(2));
  auto x = torch::randn({4, 8, 300}, torch::requires_grad());
  for (int round = 0; round < 2; ++round) {
    auto y = conv->forward(x);
    // The convolution by hand: y[b, o, t] = bias[o] + sum_{i, k} w[o, i, k] x[b, i, t + k - 2].
    auto xp = torch::constant_pad_nd(x.detach(), {2, 2});
    auto expected = torch::einsum("oik,bitk->bot", {conv->weight.detach(), xp.unfold(2, 5, 1)}) +
                    conv->bias.detach().view({1, 16, 1});
    EXPECT_TRUE(torch::allclose(y.detach(), expected, 1e-4, 1e-4));
    y.sum().backward();
    x.mutable_grad().reset();
  }
}

TEST(CpuBlockCache, ConcurrentUseKeepsTheBooksStraight) {
  use_cpu_block_cache();
  release_cpu_block_cache();
  const auto before = cpu_block_cache_stats();
  std::vector<std::thread> threads;
  for (int k = 0; k < 4; ++k)
    threads.emplace_back([k] {
      for (int i = 0; i < 50; ++i) {
        auto t = torch::full({(1 << 18) + 4096 * ((i + k) % 5)}, static_cast<float>(k));
        ASSERT_EQ(t[0].item<float>(), static_cast<float>(k));
        ASSERT_EQ(t[-1].item<float>(), static_cast<float>(k));
      }
    });
  for (auto& t : threads) t.join();
  const auto after = cpu_block_cache_stats();
  EXPECT_EQ(after.live_bytes, before.live_bytes);
  EXPECT_EQ(after.system_allocations + after.reuses - before.system_allocations - before.reuses, 200);
  EXPECT_LE(after.system_allocations - before.system_allocations, 20);  // at most 4 threads x 5 sizes
  release_cpu_block_cache();
  EXPECT_EQ(cpu_block_cache_stats().cached_bytes, 0u);
}

}  // namespace
