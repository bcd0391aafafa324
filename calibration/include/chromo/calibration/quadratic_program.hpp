#pragma once
// A small strictly convex quadratic program with bounds and linear
// equalities, and two exact solvers for it:
//
//   minimise    ½ xᵀ G x + aᵀ x
//   subject to  E x = f            (a few equalities, rows of E)
//               lower ≤ x ≤ upper  (per variable; ±infinity allowed)
//
// G must be symmetric positive definite (the mix solver's G = BᵀB with B of
// full column rank). Sizes are tiny (the mix solver has 6 variables and at
// most 3 equalities), so the matrices are dynamic Eigen types and nothing is
// tuned for large n.
//
// solve_dual_active_set: Goldfarb & Idnani's dual active-set method (Math.
// Programming 27, 1983). It starts at the unconstrained minimum, which needs
// no feasible starting point (finding one under equalities plus bounds would
// be an LP of its own), adds the most violated constraint at each step and
// drops constraints whose multiplier would turn negative; the objective rises
// monotonically, so no active set repeats and it ends after finitely many
// steps at the exact KKT point (to rounding). The factorisations are
// recomputed from a Cholesky factor and a Householder QR at each step: for
// n ≤ ~10 that is cheaper than bookkeeping and keeps it numerically simple.
//
// solve_by_enumeration: the independent check. Every variable is free, at its
// lower or at its upper bound (3^n faces); on each face the equality-
// constrained stationary point is found from the KKT system; the feasible one
// with the least objective is the optimum (for a convex problem the optimum is
// the stationary point of the face it lies on). O(3^n): fine for n ≤ 8, used
// by tests and the bench, never in production.

#include <Eigen/Core>
#include <string>

namespace chromo::calibration {

struct QuadraticProgram {
  Eigen::MatrixXd G;        // n×n, symmetric positive definite
  Eigen::VectorXd a;        // n
  Eigen::MatrixXd E;        // m×n equality rows (m may be 0)
  Eigen::VectorXd f;        // m
  Eigen::VectorXd lower;    // n, may hold -infinity
  Eigen::VectorXd upper;    // n, may hold +infinity

  double objective(const Eigen::VectorXd& x) const { return 0.5 * x.dot(G * x) + a.dot(x); }
  // Empty when the sizes agree, lower ≤ upper and nothing is NaN; else why not.
  std::string shape_error() const;
};

enum class QpTermination {
  kOptimal,          // KKT point found
  kInfeasible,       // no x satisfies the equalities within the bounds
  kNotConvex,        // G is not positive definite
  kIterationLimit,   // max_iterations add/drop steps were not enough
};
const char* qp_termination_name(QpTermination termination);

struct QpResult {
  QpTermination termination = QpTermination::kInfeasible;
  Eigen::VectorXd x;                 // the solution (meaningful for kOptimal)
  double objective = 0;
  int iterations = 0;                // add + drop steps (dual) or faces tried (enumeration)
  Eigen::VectorXi active_bound;      // per variable: -1 at lower, +1 at upper, 0 free
  Eigen::VectorXd equality_multiplier;  // m; G x + a = Eᵀ·eq_mult + bound_mult
  Eigen::VectorXd bound_multiplier;     // n; ≥ 0 at lower, ≤ 0 at upper, 0 free
};

QpResult solve_dual_active_set(const QuadraticProgram& qp, int max_iterations = 100);
QpResult solve_by_enumeration(const QuadraticProgram& qp);

}  // namespace chromo::calibration
