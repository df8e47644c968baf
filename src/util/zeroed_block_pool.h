/*
 * pcl_mi: all-zero memory blocks for the dense voxel arrays, kept between alignments.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <cstddef>

namespace pcl_mi {
namespace core {

/** \brief A block of memory from acquireZeroedBlock(): \a bytes usable bytes at \a data. */
struct ZeroedBlock {
  void* data = nullptr;
  std::size_t bytes = 0; ///< what the block holds, at least what was asked for
  bool mapped = false;   ///< from the pool's mappings (else from calloc)
};

/** \brief Blocks from this size up come from the process-wide pool; smaller ones from
 * calloc(). */
constexpr std::size_t kPooledBlockBytes = std::size_t{1} << 20;

/** \brief Most bytes of released blocks the pool keeps (beyond it, the oldest are unmapped):
 * a few grids of a fine resolution. */
constexpr std::size_t kPoolBytes = std::size_t{64} << 20;

/** \brief At least \a bytes of memory, every byte zero. A large block is one the pool kept
 * (a recent alignment's, already mapped, so touching it costs neither a page fault nor a
 * clear) or a fresh mapping, whose pages the system maps as they are first touched; from
 * 8 MiB up in 2 MiB pages where it can, since a fresh page costs far more than clearing one
 * (docs/benchmarks.md, "How the process allocates"). Throws std::bad_alloc when there is no
 * memory. Thread-safe. */
ZeroedBlock
acquireZeroedBlock(std::size_t bytes);

/** \brief Gives \a block back. With \a all_zero (the caller guarantees that every byte is
 * zero again) the pool may keep it for the next acquireZeroedBlock(); otherwise, or when
 * the pool is full, its memory goes back to the system. Thread-safe. */
void
releaseZeroedBlock(const ZeroedBlock& block, bool all_zero);

/** \brief Bytes the pool holds now (for tests). */
std::size_t
pooledZeroedBytes();

} // namespace core
} // namespace pcl_mi
