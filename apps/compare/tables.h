/*
 * pcl_mi_compare: the paper's tables from result rows (mean error per initial-error bin,
 * runtime, success) and the signed bias per direction.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "compare/rows.h"

#include <string>
#include <vector>

namespace pcl_mi {
namespace compare {

/** Prints every table for \a methods (in that order), with \a success = {m, deg}. */
void
printTables(const std::vector<Row>& rows,
            const std::vector<std::string>& methods,
            const std::vector<double>& success);

} // namespace compare
} // namespace pcl_mi
