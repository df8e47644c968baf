/*
 * pcl_mi: derivative-free Nelder-Mead minimisation of a function of a few parameters.
 * Knows nothing about clouds; tested on known functions.
 * SPDX-License-Identifier: BSD-3-Clause
 */
#pragma once

#include <Eigen/Core>

#include <functional>
#include <vector>

namespace pcl_mi {
namespace core {

/** \brief Stopping rules of one Nelder-Mead run. */
struct NelderMeadOptions {
  /** Iteration cap (one reflection/expansion/contraction/shrink step each). */
  int max_iterations = 500;
  /** Converged when every vertex is within tolerance[i] of the best vertex in every
   * coordinate i. */
  Eigen::VectorXd tolerance;
  /** Each iteration asks for its reflection, expansion and both contractions in one
   * request, for a function whose cost is the round trip, not the evaluation (a GPU). The
   * vertices chosen, and so the result, are those of the one-at-a-time run. */
  bool speculative = false;
};

/** \brief Outcome of one Nelder-Mead run. */
struct NelderMeadResult {
  Eigen::VectorXd x;      ///< best vertex
  double value = 0.0;     ///< function value at x
  int iterations = 0;     ///< iterations performed
  int evaluations = 0;    ///< evaluations the method uses (speculative ones not counted)
  int requests = 0;       ///< requests answered (rounds this run took part in)
  bool converged = false; ///< simplex met the tolerance (false: iteration cap)
};

/** \brief Values of several points at once: values[i] = f(points[i]). */
using BatchFunction =
    std::function<void(const std::vector<Eigen::VectorXd>& points, std::vector<double>& values)>;

/** \brief One Nelder-Mead minimisation driven from outside (ask and tell): request() names
 * the points whose values the run needs next, reply() hands them over. Several runs can so
 * share one batch of evaluations; each run's choices, and so its result, depend only on the
 * values it is told, never on how its requests were batched.
 *
 * Standard coefficients: reflection 1, expansion 2, contraction 1/2, shrink 1/2. The
 * initial simplex is x0 and x0 + steps[i] * e_i for each i: the sign of a step chooses the
 * side of x0 on which that edge of the simplex lies. */
class NelderMeadRun {
public:
  NelderMeadRun(const Eigen::VectorXd& x0,
                const Eigen::VectorXd& steps,
                const NelderMeadOptions& options);

  /** \brief True when the run met its tolerance or its iteration cap. */
  bool
  finished() const
  {
    return request_.empty();
  }

  /** \brief The points to evaluate next (empty once finished). */
  const std::vector<Eigen::VectorXd>&
  request() const
  {
    return request_;
  }

  /** \brief The values of request()'s points, in its order; the run then moves on to its
   * next request. */
  void
  reply(const std::vector<double>& values);

  /** \brief A point the run may ask for right after request(), worth evaluating beside it
   * where an evaluator would otherwise wait: while the reflection is asked alone, the inside
   * contraction, the step that most iterations which need a second point take near an
   * optimum. Null where there is none. */
  const Eigen::VectorXd*
  spare() const;

  /** \brief The value of spare(), handed over before reply(): the run uses it where it
   * needs that point, as if it had asked for it, so the result is the same either way. */
  void
  offerSpare(double value);

  /** \brief The best vertex so far, with the counts (final once finished()). */
  NelderMeadResult
  result() const;

private:
  /** The candidates of one iteration, in the order a speculative request holds them. */
  enum Candidate { kReflected, kExpanded, kOutsideContracted, kInsideContracted, kCandidates };
  enum class Phase { kSimplex, kCandidates, kShrink };

  void
  beginIteration();
  /** Decides the iteration from the candidate values known so far: asks for the next one
   * it needs, or replaces the worst vertex (or shrinks) and begins the next iteration. */
  void
  decide();
  void
  replaceWorst(Candidate c);

  NelderMeadOptions options_;
  Eigen::VectorXd tolerance_;
  std::vector<Eigen::VectorXd> vertices_;
  std::vector<double> values_;
  std::size_t best_ = 0, worst_ = 0, second_worst_ = 0;
  Eigen::VectorXd candidates_[kCandidates];
  double candidate_values_[kCandidates] = {};
  bool known_[kCandidates] = {};
  bool used_[kCandidates] = {};
  std::vector<Candidate> asked_;
  Phase phase_ = Phase::kSimplex;
  std::vector<Eigen::VectorXd> request_;
  NelderMeadResult counts_;
};

/** \brief Minimises \a f with the Nelder-Mead simplex method (NelderMeadRun, one point at a
 * time). */
NelderMeadResult
minimizeNelderMead(const std::function<double(const Eigen::VectorXd&)>& f,
                   const Eigen::VectorXd& x0,
                   const Eigen::VectorXd& steps,
                   const NelderMeadOptions& options);

/** \brief Drives \a run to its end, one request per call of \a f. Returns the number of
 * calls. */
int
runToEnd(NelderMeadRun& run, const BatchFunction& f);

/** \brief Drives every run of \a runs to its end, handing the requests of all unfinished
 * runs to \a f as one batch per round. Returns the number of rounds (calls of \a f). */
int
runTogether(std::vector<NelderMeadRun>& runs, const BatchFunction& f);

} // namespace core
} // namespace pcl_mi
