/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "util/zeroed_block_pool.h"

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <mutex>
#include <new>
#include <vector>

#if defined(__unix__)
#include <sys/mman.h>
#include <unistd.h>
#define PCL_MI_HAVE_MMAP 1
#endif

namespace pcl_mi {
namespace core {

namespace {

constexpr std::size_t kPageBytes = std::size_t{4} << 10;
constexpr std::size_t kHugePageBytes = std::size_t{2} << 20;
/** Blocks from this size up are backed by huge pages where the system allows. */
constexpr std::size_t kHugeBlockBytes = std::size_t{8} << 20;

std::size_t
roundUp(std::size_t bytes, std::size_t unit)
{
  return (bytes + unit - 1) / unit * unit;
}

/** The released blocks, oldest first. Never destroyed: blocks may be released by objects
 * that outlive static destruction. */
struct Pool {
  std::mutex mutex;
  std::vector<ZeroedBlock> kept;
  std::size_t kept_bytes = 0;
#ifdef PCL_MI_HAVE_MMAP
  pid_t owner = ::getpid();
#endif
};

Pool&
pool()
{
  static Pool* p = new Pool;
#ifdef PCL_MI_HAVE_MMAP
  // A forked child starts a pool of its own: a parent's thread may have held the mutex at
  // the fork. The parent's blocks stay mapped in the child, unused.
  if (p->owner != ::getpid())
    p = new Pool;
#endif
  return *p;
}

#ifdef PCL_MI_HAVE_MMAP
/** A fresh anonymous mapping of \a bytes (a multiple of the page size, or of 2 MiB for
 * huge pages, then aligned to 2 MiB), or null. */
void*
mapFresh(std::size_t bytes, bool huge)
{
  const std::size_t extra = huge ? kHugePageBytes : 0;
  void* raw = mmap(nullptr, bytes + extra, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS,
                   -1, 0);
  if (raw == MAP_FAILED)
    return nullptr;
  if (!huge)
    return raw;
  // Trim the mapping to a 2 MiB-aligned range, which the system can back by huge pages.
  const auto begin = reinterpret_cast<std::uintptr_t>(raw);
  const std::uintptr_t aligned = roundUp(begin, kHugePageBytes);
  if (aligned > begin)
    munmap(raw, aligned - begin);
  const std::uintptr_t end = begin + bytes + extra;
  if (end > aligned + bytes)
    munmap(reinterpret_cast<void*>(aligned + bytes), end - aligned - bytes);
#ifdef MADV_HUGEPAGE
  madvise(reinterpret_cast<void*>(aligned), bytes, MADV_HUGEPAGE); // a hint: failure is fine
#endif
  return reinterpret_cast<void*>(aligned);
}
#endif

void
freeBlock(const ZeroedBlock& block)
{
#ifdef PCL_MI_HAVE_MMAP
  if (block.mapped) {
    munmap(block.data, block.bytes);
    return;
  }
#endif
  std::free(block.data);
}

} // namespace

ZeroedBlock
acquireZeroedBlock(std::size_t bytes)
{
  ZeroedBlock block;
#ifdef PCL_MI_HAVE_MMAP
  if (bytes >= kPooledBlockBytes) {
    const bool huge = bytes >= kHugeBlockBytes;
    const std::size_t size = roundUp(bytes, huge ? kHugePageBytes : kPageBytes);
    {
      // The smallest kept block that fits, if it is not more than twice the size.
      Pool& p = pool();
      std::lock_guard<std::mutex> lock(p.mutex);
      auto best = p.kept.end();
      for (auto it = p.kept.begin(); it != p.kept.end(); ++it)
        if (it->bytes >= size && it->bytes <= 2 * size &&
            (best == p.kept.end() || it->bytes < best->bytes))
          best = it;
      if (best != p.kept.end()) {
        block = *best;
        p.kept_bytes -= best->bytes;
        p.kept.erase(best);
        return block;
      }
    }
    block.data = mapFresh(size, huge);
    if (!block.data)
      throw std::bad_alloc();
    block.bytes = size;
    block.mapped = true;
    return block;
  }
#endif
  block.data = std::calloc(std::max<std::size_t>(bytes, 1), 1);
  if (!block.data)
    throw std::bad_alloc();
  block.bytes = bytes;
  return block;
}

void
releaseZeroedBlock(const ZeroedBlock& block, bool all_zero)
{
  if (!block.data)
    return;
  if (!block.mapped || !all_zero || block.bytes > kPoolBytes) {
    freeBlock(block);
    return;
  }
  std::vector<ZeroedBlock> evicted;
  {
    Pool& p = pool();
    std::lock_guard<std::mutex> lock(p.mutex);
    p.kept.push_back(block);
    p.kept_bytes += block.bytes;
    while (p.kept_bytes > kPoolBytes) {
      evicted.push_back(p.kept.front());
      p.kept_bytes -= p.kept.front().bytes;
      p.kept.erase(p.kept.begin());
    }
  }
  for (const ZeroedBlock& b : evicted)
    freeBlock(b);
}

std::size_t
pooledZeroedBytes()
{
  Pool& p = pool();
  std::lock_guard<std::mutex> lock(p.mutex);
  return p.kept_bytes;
}

} // namespace core
} // namespace pcl_mi
