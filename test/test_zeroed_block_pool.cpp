/*
 * The zeroed blocks: every block comes all zero, a block given back all zero serves the next
 * request of its size, and one given back dirty does not.
 */
#include "util/zeroed_array.h"
#include "util/zeroed_block_pool.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <vector>

namespace {

using pcl_mi::core::acquireZeroedBlock;
using pcl_mi::core::pooledZeroedBytes;
using pcl_mi::core::releaseZeroedBlock;
using pcl_mi::core::ZeroedArray;
using pcl_mi::core::ZeroedBlock;

bool
allZero(const ZeroedBlock& b, std::size_t bytes)
{
  const auto* p = static_cast<const unsigned char*>(b.data);
  return std::all_of(p, p + bytes, [](unsigned char c) { return c == 0; });
}

TEST(ZeroedBlockPool, ABlockGivenBackZeroServesTheNextRequestAndADirtyOneDoesNot)
{
  const std::size_t bytes = 3 * pcl_mi::core::kPooledBlockBytes + 123;
  ZeroedBlock a = acquireZeroedBlock(bytes);
  ASSERT_NE(a.data, nullptr);
  EXPECT_GE(a.bytes, bytes);
  EXPECT_TRUE(allZero(a, bytes));
  auto* p = static_cast<unsigned char*>(a.data);
  p[0] = 1;
  p[bytes / 2] = 2;
  p[bytes - 1] = 3;
  std::memset(p, 0, a.bytes); // as an owner clears what it set
  const std::size_t before = pooledZeroedBytes();
  releaseZeroedBlock(a, true);
  EXPECT_EQ(pooledZeroedBytes(), before + a.bytes);

  // A kept block (this one, or another of the process's that fits), not a fresh mapping.
  ZeroedBlock b = acquireZeroedBlock(bytes);
  EXPECT_EQ(pooledZeroedBytes(), before + a.bytes - b.bytes);
  EXPECT_TRUE(allZero(b, bytes));
  static_cast<unsigned char*>(b.data)[7] = 9; // dirty: must not come back
  releaseZeroedBlock(b, false);
  EXPECT_EQ(pooledZeroedBytes(), before);
  ZeroedBlock c = acquireZeroedBlock(bytes);
  EXPECT_TRUE(allZero(c, bytes));
  releaseZeroedBlock(c, false);
}

TEST(ZeroedBlockPool, SmallBlocksComeFromCallocAndAreNotKept)
{
  const std::size_t before = pooledZeroedBytes();
  ZeroedBlock b = acquireZeroedBlock(1000);
  EXPECT_FALSE(b.mapped);
  EXPECT_TRUE(allZero(b, 1000));
  releaseZeroedBlock(b, true);
  EXPECT_EQ(pooledZeroedBytes(), before);
}

TEST(ZeroedBlockPool, AnArrayThatReturnsZeroedIsReusedAllZero)
{
  struct Cell {
    std::uint32_t count;
    std::uint32_t sum;
    std::uint64_t square;
  };
  const std::size_t size = 5 * pcl_mi::core::kPooledBlockBytes / sizeof(Cell);
  for (int round = 0; round < 3; ++round) {
    const std::size_t pooled = pooledZeroedBytes();
    ZeroedArray<Cell> cells(size);
    for (std::size_t i = 0; i < size; i += 997)
      ASSERT_EQ(cells[i].count + cells[i].sum + cells[i].square, 0u) << "round " << round;
    if (round > 0) // the previous round's block, or another kept one: no fresh mapping
      EXPECT_LT(pooledZeroedBytes(), pooled) << "round " << round;
    std::vector<std::size_t> touched;
    for (std::size_t i = round; i < size; i += 4099) {
      cells[i] = {1, 2, 3};
      touched.push_back(i);
    }
    for (const std::size_t i : touched)
      cells[i] = Cell{};
    cells.returnsZeroed();
  }
}

} // namespace
