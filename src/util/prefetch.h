/*
 * pcl_mi: a hint that memory will be read soon.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

namespace pcl_mi {
namespace core {

/** \brief Starts reading the cache line that holds \a address, so that a later use of it
 * need not wait; a no-op for compilers without the builtin. */
inline void
prefetch(const void* address)
{
#if defined(__GNUC__) || defined(__clang__)
  __builtin_prefetch(address);
#else
  (void)address;
#endif
}

} // namespace core
} // namespace pcl_mi
