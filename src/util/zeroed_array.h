/*
 * pcl_mi: a fixed-size array of zero-initialised trivial values whose pages the system
 * maps only when first touched.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <cstddef>
#include <cstdlib>
#include <memory>
#include <new>
#include <type_traits>

namespace pcl_mi {
namespace core {

/** \brief \a size values of \a T, all bytes zero, from calloc(): a large block comes as fresh
 * zero pages, so a dense voxel grid of which an alignment touches a few rows costs only the
 * pages of those rows, where std::vector would write every byte first. \a T must be a
 * plain aggregate (trivially copyable and destructible) whose all-zero bytes are its
 * default value. */
template <typename T>
class ZeroedArray {
  static_assert(std::is_trivially_copyable<T>::value && std::is_trivially_destructible<T>::value,
                "ZeroedArray holds plain values only");

public:
  ZeroedArray() = default;
  explicit ZeroedArray(std::size_t size) : size_(size)
  {
    if (size == 0)
      return;
    data_.reset(static_cast<T*>(std::calloc(size, sizeof(T))));
    if (!data_)
      throw std::bad_alloc();
  }

  std::size_t
  size() const
  {
    return size_;
  }
  T&
  operator[](std::size_t i)
  {
    return data_.get()[i];
  }
  const T&
  operator[](std::size_t i) const
  {
    return data_.get()[i];
  }

private:
  struct Free {
    void
    operator()(T* p) const
    {
      std::free(p);
    }
  };
  std::unique_ptr<T[], Free> data_;
  std::size_t size_ = 0;
};

} // namespace core
} // namespace pcl_mi
