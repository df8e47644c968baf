/*
 * pcl_mi: a refused result confirmed by the alignment of the clouds swapped.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include "verify/verification.h"

#include <pcl_mi/types.h>

namespace pcl_mi {
namespace core {

/** Confidence from which a refused result is worth the alignment of the clouds swapped. */
constexpr double kConfirmableConfidence = 0.8;
/** Confidence from which that alignment's result may confirm it. */
constexpr double kConfirmingConfidence = 0.5;
/** How close the swapped alignment's result, inverted, must end to the result: half the
 * success bound's shift, a quarter of its turn. */
constexpr double kAgreementShiftMetres = kSuccessShiftMetres / 2.0;
constexpr double kAgreementTurnDeg = kSuccessTurnDeg / 4.0;
/** How close in turn where the swapped alignment holds the turn that the result leaves free
 * (holdsTheFreeTurn()): the success bound's turn. */
constexpr double kHeldFreeTurnAgreementDeg = kSuccessTurnDeg;

/** \brief True where the poses \a pose and \a other, of one problem, end within
 * kAgreementShiftMetres (times \a units_per_metre) and kAgreementTurnDeg of each other: the
 * turn, and the shift of the target frame's origin, of other^-1 * pose. */
bool
endsTogether(const Eigen::Matrix4d& pose, const Eigen::Matrix4d& other, double units_per_metre);

/** \brief True where \a result, refused by the reliability test as degenerate, for weak
 * evidence, a second optimum or too little shared surface, or passed with its search capped,
 * has a confidence of at least kConfirmableConfidence after judgeSteadiness(): worth aligning
 * the clouds swapped. */
bool
mayBeConfirmed(const AlignmentResult& result);

/** \brief True where \a v, a result's verdict, refuses it as degenerate with only turns free
 * (onlyTurnsFree()) and \a w, the swapped alignment's, passes every test itself, with a
 * confidence of at least kReliableConfidence: that side holds the turn the result leaves
 * free. */
bool
holdsTheFreeTurn(const Verification& v, const Verification& w);

/** Least share (of its squared length) of a direction the result leaves free that must lie
 * outside the directions the swapped alignment leaves free, for that alignment to hold it:
 * the two free directions at least 45 degrees apart. */
constexpr double kHeldAcrossShare = 0.5;

/** \brief True where \a w, the verdict of the swapped alignment that ended at \a back, holds
 * every direction that \a v, the result's verdict, leaves free: each, carried over to \a back
 * and in \a w's observability units, lies at least kHeldAcrossShare outside the directions
 * \a w leaves free. Two sides that leave different directions free each hold what the other
 * leaves, and where they agree, every direction is held. */
bool
holdsTheFreeDirections(const Verification& v, const Verification& w, const Eigen::Matrix4d& back);

/** \brief Weighs \a back, the alignment of the clouds swapped from the inverse of the guess,
 * against \a result: sets Verification::reverse_shift and reverse_turn_deg from the
 * difference of \a result and the inverse of \a back's pose (the turn, and the shift of the
 * target frame's origin, its sensor), and converges \a result where
 * - \a back's verdict finds enough shared surface, with a confidence of at least
 *   kConfirmingConfidence, and leaves no direction free, or \a result holds every direction
 *   itself, on enough surface, and names no second optimum (weak evidence, or passed with
 *   its search capped): a free side says nothing along its free direction, the result's own
 *   evidence does; or \a result is degenerate and \a back holds every direction it leaves
 *   free (holdsTheFreeDirections()),
 * - and the two end within kAgreementShiftMetres (times \a units_per_metre) and
 *   kAgreementTurnDeg of each other (kHeldFreeTurnAgreementDeg where \a back holds the turn
 *   \a result leaves free, holdsTheFreeTurn()).
 * A confirmed result takes kReverseConfirmedConfidence and, where its own has none (a free
 * direction), \a back's covariance carried over to its pose, or where \a back has none
 * either, the inverse of the two sides' mean information (Verification::information); one
 * it does not confirm takes kReverseUnconfirmedConfidence (nothing changes where \a back
 * failed). Whether either
 * search met its tolerance does not matter: two searches that end at one pose from opposite
 * sides found one optimum, however wide their simplices still were at the cap. Returns
 * whether it confirmed. */
bool
confirmWithTheReverse(const AlignmentResult& back, double units_per_metre, AlignmentResult& result);

} // namespace core
} // namespace pcl_mi
