/*
 * pcl_mi: a fixed-size array of zero-initialised trivial values, on memory that is either
 * kept from an earlier array or mapped only where first touched.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "util/zeroed_block_pool.h"

#include <cstddef>
#include <type_traits>
#include <utility>

namespace pcl_mi {
namespace core {

/** \brief \a size values of \a T, all bytes zero, from acquireZeroedBlock(): a large array
 * comes either as a block an earlier array gave back all zero, or as fresh zero pages, so
 * a dense voxel grid of which an alignment touches a few rows costs only the pages of those
 * rows, where std::vector would write every byte first. An owner that clears every value it
 * set before the array goes (returnsZeroed()) lets the next array take its memory as it is.
 * \a T must be a plain aggregate (trivially copyable and destructible) whose all-zero bytes
 * are its default value. */
template <typename T>
class ZeroedArray {
  static_assert(std::is_trivially_copyable<T>::value && std::is_trivially_destructible<T>::value,
                "ZeroedArray holds plain values only");

public:
  ZeroedArray() = default;
  explicit ZeroedArray(std::size_t size) : size_(size)
  {
    if (size > 0)
      block_ = acquireZeroedBlock(size * sizeof(T));
  }
  ~ZeroedArray() { release(); }
  ZeroedArray(ZeroedArray&& other) noexcept
  : block_(std::exchange(other.block_, ZeroedBlock{})),
    size_(std::exchange(other.size_, 0)),
    returns_zeroed_(other.returns_zeroed_)
  {}
  ZeroedArray&
  operator=(ZeroedArray&& other) noexcept
  {
    if (this != &other) {
      release();
      block_ = std::exchange(other.block_, ZeroedBlock{});
      size_ = std::exchange(other.size_, 0);
      returns_zeroed_ = other.returns_zeroed_;
    }
    return *this;
  }
  ZeroedArray(const ZeroedArray&) = delete;
  ZeroedArray&
  operator=(const ZeroedArray&) = delete;

  /** \brief The owner's promise: every value is zero again whenever this array is destroyed
   * or replaced, so its memory may serve the next array without a clear. */
  void
  returnsZeroed()
  {
    returns_zeroed_ = true;
  }

  std::size_t
  size() const
  {
    return size_;
  }
  T&
  operator[](std::size_t i)
  {
    return static_cast<T*>(block_.data)[i];
  }
  const T&
  operator[](std::size_t i) const
  {
    return static_cast<const T*>(block_.data)[i];
  }

private:
  void
  release()
  {
    releaseZeroedBlock(block_, returns_zeroed_);
    block_ = ZeroedBlock{};
    size_ = 0;
  }

  ZeroedBlock block_;
  std::size_t size_ = 0;
  bool returns_zeroed_ = false;
};

} // namespace core
} // namespace pcl_mi
