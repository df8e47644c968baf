/*
 * pcl_mi io: the format readers behind pcl_mi::io::loadCloud() (internal).
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <pcl_mi/io.h>

#include <string>

namespace pcl_mi {
namespace io {
namespace detail {

/** Reads a PCD file (ascii, binary or binary_compressed; fields of any numeric type).
 * Every size the header announces is checked in 64-bit arithmetic against the file's own
 * size before anything is allocated. Empty on success, else a one-line reason. */
std::string
readPcd(const std::string& path, ScanPoints& cloud);

/** Reads the vertex element of a PLY file (ascii or binary of either byte order; list
 * properties and other elements are skipped). Same checks and contract as readPcd(). */
std::string
readPly(const std::string& path, ScanPoints& cloud);

/** \a v as float, beyond float's range as +-infinity (a plain conversion is undefined). */
float
toFloat(double v);

} // namespace detail
} // namespace io
} // namespace pcl_mi
