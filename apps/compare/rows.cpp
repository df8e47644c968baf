/*
 * SPDX-License-Identifier: BSD-3-Clause
 */
#include "compare/rows.h"

#include "app_util.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <fstream>
#include <iomanip>
#include <iterator>
#include <limits>

namespace pcl_mi {
namespace compare {

namespace {
constexpr std::size_t kLegacyFields = 14;
constexpr std::size_t kPoseFields = kLegacyFields + 3 + 2 * 12;
constexpr std::size_t kVerdictFields = kPoseFields + 7;
constexpr std::size_t kEvidenceFields = kVerdictFields + 7; // before the lead
constexpr std::size_t kLeadFields = kEvidenceFields + 1;
constexpr std::size_t kTurnLossFields = kLeadFields + 1; // the free turns' MI loss
constexpr std::size_t kTurnShareFields = kTurnLossFields + 1; // the weaker direction's turn share
constexpr std::size_t kReasonFields = kTurnShareFields + 2; // MI's refusal and its reason
constexpr std::size_t kRestartFields = kReasonFields + 2; // the restarts' turn and shift
constexpr std::size_t kFields = kRestartFields + 2; // the clouds swapped: shift and turn
/** The column counts of the formats readRows() accepts, each the first columns of the next. */
constexpr std::size_t kFormats[] = {kLegacyFields,   kPoseFields,      kVerdictFields,
                                    kEvidenceFields, kLeadFields,      kTurnLossFields,
                                    kTurnShareFields, kReasonFields,   kRestartFields,
                                    kFields};

/** The first \a n columns of the CSV line \a line. */
std::string
firstColumns(const std::string& line, std::size_t n)
{
  std::size_t end = 0;
  for (std::size_t i = 0; i < n && end != std::string::npos; ++i)
    end = line.find(',', end + (i > 0));
  return line.substr(0, end);
}

/** \a line's comma-separated fields; a field in double quotes may hold commas, and two
 * double quotes in it stand for one (RFC 4180). */
std::vector<std::string>
csvFields(const std::string& line)
{
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted && c == '"' && i + 1 < line.size() && line[i + 1] == '"')
      fields.back() += line[++i];
    else if (c == '"')
      quoted = !quoted;
    else if (c == ',' && !quoted)
      fields.emplace_back();
    else
      fields.back() += c;
  }
  return fields;
}

/** \a text in double quotes, its own double quotes doubled (RFC 4180). */
std::string
quoted(const std::string& text)
{
  std::string q = "\"";
  for (const char c : text)
    q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + '"';
}
} // namespace

/** The first 14 columns are the original format, which readRows() still accepts with the
 * later ones (kFormats); the columns after them keep what an analysis beyond these tables
 * needs: the signed error components and both transforms (top three rows, row-major), MI's
 * verdict, its evidence and its refusal. */
std::string
csvHeader()
{
  std::string h = "sequence,target,source,direction,true_translation_m,true_rotation_deg,"
                  "initial_translation_m,initial_rotation_deg,method,translation_error_m,"
                  "rotation_error_deg,seconds,converged,evaluations";
  h += ",along_error_m,left_error_m,up_error_m";
  for (const char* name : {"estimate", "reference"})
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c)
        h += "," + std::string(name) + "_" + std::to_string(r) + std::to_string(c);
  h += ",confidence,sd_x_m,sd_y_m,sd_z_m,sd_roll_deg,sd_pitch_deg,sd_yaw_deg";
  h += ",search_converged,inliers,inlier_fraction,peak_contrast,weakest_contrast,normalized_mi,"
       "free_direction_contrast,lead,free_turn_mi_loss,free_direction_turn_share,refusal,reason";
  h += ",restart_turn_deg,restart_shift_m";
  h += ",reverse_shift_m,reverse_turn_deg";
  return h;
}

/** \a error = estimate - reference translation (target frame) along the reference
 * translation, to its left and up; NaN where the travel direction is undefined. */
Eigen::Vector3d
travelFrameError(const Eigen::Matrix4d& estimate, const Eigen::Matrix4d& reference)
{
  const Eigen::Vector3d t = reference.topRightCorner<3, 1>();
  const Eigen::Vector3d along = t.normalized();
  const Eigen::Vector3d left_raw = Eigen::Vector3d::UnitZ().cross(along);
  // Below 1 mm of motion, or within 0.6 deg of vertical, "along" and "left" say nothing.
  if (!(t.norm() > 1e-3) || !(left_raw.norm() > 1e-2))
    return Eigen::Vector3d::Constant(NAN);
  const Eigen::Vector3d left = left_raw.normalized();
  const Eigen::Vector3d up = along.cross(left);
  const Eigen::Vector3d error = estimate.topRightCorner<3, 1>() - t;
  return {error.dot(along), error.dot(left), error.dot(up)};
}

void
writeRow(std::ostream& out, const Row& r)
{
  out << r.sequence << ',' << r.target << ',' << r.source << ',' << r.direction << ','
      << r.true_translation << ',' << r.true_rotation << ',' << r.initial_translation << ','
      << r.initial_rotation << ',' << r.method << ',' << r.translation_error << ','
      << r.rotation_error << ',' << r.seconds << ',' << r.converged << ',' << r.evaluations;
  for (int i = 0; i < 3; ++i)
    out << ',' << r.travel_error[i];
  const auto precision = out.precision(9); // enough for a float transform to round-trip
  for (const Eigen::Matrix4d* m : {&r.estimate, &r.reference})
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 4; ++j)
        out << ',' << (*m)(i, j);
  out.precision(precision);
  out << ',' << r.confidence;
  for (double sd : r.sigma)
    out << ',' << sd;
  for (double e : r.evidence)
    out << ',' << e;
  out << ',' << r.refusal << ',' << quoted(r.reason) << ',' << r.restart_turn_deg << ','
      << r.restart_shift << ',' << r.reverse_shift << ',' << r.reverse_turn_deg << '\n';
}

/** Reads rows written by writeRow(); false with \a error on a malformed file. */
bool
readRows(const std::string& path, std::vector<Row>& rows, std::string& error)
{
  std::ifstream in(path);
  if (!in) {
    error = "cannot open '" + path + "'";
    return false;
  }
  std::string line;
  int number = 0;
  const std::string header = csvHeader();
  std::vector<std::string> headers; // the header of each format
  for (const std::size_t n : kFormats)
    headers.push_back(firstColumns(header, n));
  while (std::getline(in, line)) {
    ++number;
    if (line.empty() || std::find(headers.begin(), headers.end(), line) != headers.end())
      continue;
    const std::vector<std::string> f = csvFields(line);
    try {
      if (std::find(std::begin(kFormats), std::end(kFormats), f.size()) == std::end(kFormats))
        throw std::invalid_argument("field count");
      Row r;
      r.sequence = f[0];
      r.target = std::stoi(f[1]);
      r.source = std::stoi(f[2]);
      r.direction = f[3];
      r.true_translation = std::stod(f[4]);
      r.true_rotation = std::stod(f[5]);
      r.initial_translation = std::stod(f[6]);
      r.initial_rotation = std::stod(f[7]);
      r.method = f[8];
      r.translation_error = std::stod(f[9]);
      r.rotation_error = std::stod(f[10]);
      r.seconds = std::stod(f[11]);
      r.converged = f[12] == "1";
      r.evaluations = std::stoi(f[13]);
      if (f.size() >= kPoseFields) {
        std::size_t k = kLegacyFields;
        for (int i = 0; i < 3; ++i)
          r.travel_error[i] = std::stod(f[k++]);
        for (Eigen::Matrix4d* m : {&r.estimate, &r.reference}) {
          m->row(3) << 0.0, 0.0, 0.0, 1.0;
          for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 4; ++j)
              (*m)(i, j) = std::stod(f[k++]);
        }
        if (f.size() >= kVerdictFields) {
          r.confidence = std::stod(f[k++]);
          for (double& sd : r.sigma)
            sd = std::stod(f[k++]);
        }
        for (double& e : r.evidence)
          if (k < kTurnShareFields && k < f.size())
            e = std::stod(f[k++]);
        if (f.size() >= kReasonFields) {
          r.refusal = f[kTurnShareFields];
          r.reason = f[kTurnShareFields + 1];
        }
        if (f.size() >= kRestartFields) {
          r.restart_turn_deg = std::stod(f[kReasonFields]);
          r.restart_shift = std::stod(f[kReasonFields + 1]);
        }
        if (f.size() >= kFields) {
          r.reverse_shift = std::stod(f[kRestartFields]);
          r.reverse_turn_deg = std::stod(f[kRestartFields + 1]);
        }
      }
      rows.push_back(r);
    }
    catch (const std::exception&) {
      error = "'" + path + "' line " + std::to_string(number) + " is not a pcl_mi_compare row";
      return false;
    }
  }
  return true;
}

} // namespace compare
} // namespace pcl_mi
