#include "chromo/calibration/quadratic_program.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <initializer_list>
#include <limits>
#include <random>

namespace chromo::calibration {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Dynamic-size literals (fixed-size 2-vectors trip a false -Warray-bounds in GCC 12 with AVX).
Eigen::VectorXd vec(std::initializer_list<double> values) {
  Eigen::VectorXd v(static_cast<Eigen::Index>(values.size()));
  Eigen::Index i = 0;
  for (double x : values) v[i++] = x;
  return v;
}
Eigen::MatrixXd mat2(double a, double b, double c, double d) {
  Eigen::MatrixXd m(2, 2);
  m << a, b, c, d;
  return m;
}

// A random strictly convex QP shaped like the mix problem: least squares on
// `rows` samples of 6 nearly collinear columns, bounds [0, upper], m equalities
// satisfiable by a point inside the box.
QuadraticProgram random_problem(std::mt19937_64& random, int m, double upper) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const int n = 6, rows = 40;
  Eigen::MatrixXd b(rows, n);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < n; ++c) b(r, c) = (c < 3 ? 1.0 + 0.05 * u(random) : 0.0) + u(random);
  Eigen::VectorXd target(rows);
  for (int r = 0; r < rows; ++r) target[r] = 4.0 * u(random) - 1.0;
  QuadraticProgram qp;
  qp.G = b.transpose() * b;
  qp.a = -b.transpose() * target;
  qp.E = Eigen::MatrixXd::Random(m, n);
  Eigen::VectorXd inside(n);
  for (int i = 0; i < n; ++i) inside[i] = std::min(upper, 2.0) * u(random);
  qp.f = qp.E * inside;
  qp.lower = Eigen::VectorXd::Zero(n);
  qp.upper = Eigen::VectorXd::Constant(n, upper);
  return qp;
}

void expect_kkt(const QuadraticProgram& qp, const QpResult& r) {
  ASSERT_EQ(r.termination, QpTermination::kOptimal);
  const double scale = 1.0 + qp.a.norm();
  const Eigen::VectorXd stationarity = qp.G * r.x + qp.a - qp.E.transpose() * r.equality_multiplier - r.bound_multiplier;
  EXPECT_LT(stationarity.norm(), 1e-8 * scale);
  for (int i = 0; i < r.x.size(); ++i) {
    EXPECT_GE(r.x[i], qp.lower[i] - 1e-9);
    EXPECT_LE(r.x[i], qp.upper[i] + 1e-9);
    if (r.active_bound[i] < 0) {
      EXPECT_GE(r.bound_multiplier[i], -1e-8 * scale);
    } else if (r.active_bound[i] > 0) {
      EXPECT_LE(r.bound_multiplier[i], 1e-8 * scale);
    } else {
      EXPECT_EQ(r.bound_multiplier[i], 0.0);
    }
  }
  if (qp.E.rows() > 0) {
    EXPECT_LT((qp.E * r.x - qp.f).norm(), 1e-9 * (1.0 + qp.f.norm()));
  }
}

TEST(QuadraticProgram, DualActiveSetMatchesEnumerationOnRandomProblems) {
  std::mt19937_64 random(42);
  int with_active_bounds = 0;
  for (int trial = 0; trial < 200; ++trial) {
    const int m = trial % 4;  // 0..3 equalities
    const QuadraticProgram qp = random_problem(random, m, trial % 5 == 0 ? kInf : 1.0 + (trial % 3));
    const QpResult dual = solve_dual_active_set(qp);
    const QpResult brute = solve_by_enumeration(qp);
    ASSERT_EQ(brute.termination, QpTermination::kOptimal) << trial;
    expect_kkt(qp, dual);
    EXPECT_NEAR(dual.objective, brute.objective, 1e-9 * std::abs(brute.objective) + 1e-12) << trial;
    EXPECT_LT((dual.x - brute.x).norm(), 1e-6 * (1.0 + brute.x.norm())) << trial;
    with_active_bounds += dual.active_bound.cwiseAbs().sum() > 0;
  }
  EXPECT_GT(with_active_bounds, 100);  // the test exercises the bounds, not just the interior
}

TEST(QuadraticProgram, UnconstrainedMinimumNeedsNoSteps) {
  QuadraticProgram qp;
  qp.G = mat2(2, 0, 0, 4);
  qp.a = vec({-2, -4});  // minimum at (1, 1)
  qp.E.resize(0, 2);
  qp.f.resize(0);
  qp.lower = vec({0, 0});
  qp.upper = vec({2, 2});
  const QpResult r = solve_dual_active_set(qp);
  ASSERT_EQ(r.termination, QpTermination::kOptimal);
  EXPECT_NEAR(r.x[0], 1.0, 1e-12);
  EXPECT_NEAR(r.x[1], 1.0, 1e-12);
  EXPECT_EQ(r.iterations, 0);
  qp.upper = vec({0.5, 2});  // now x0 sits at its upper bound with multiplier G·x+a = -1
  const QpResult bounded = solve_dual_active_set(qp);
  EXPECT_NEAR(bounded.x[0], 0.5, 1e-12);
  EXPECT_EQ(bounded.active_bound[0], 1);
  EXPECT_NEAR(bounded.bound_multiplier[0], -1.0, 1e-12);
}

TEST(QuadraticProgram, ReportsInfeasibleAndNonConvexProblems) {
  QuadraticProgram qp;
  qp.G = Eigen::MatrixXd::Identity(2, 2);
  qp.a = Eigen::VectorXd::Zero(2);
  qp.E = mat2(1, 1, 0, 0).topRows(1);
  qp.f = Eigen::VectorXd::Constant(1, 5.0);  // x0 + x1 = 5 with both in [0, 2]: impossible
  qp.lower = Eigen::VectorXd::Zero(2);
  qp.upper = Eigen::VectorXd::Constant(2, 2.0);
  EXPECT_EQ(solve_dual_active_set(qp).termination, QpTermination::kInfeasible);
  EXPECT_EQ(solve_by_enumeration(qp).termination, QpTermination::kInfeasible);
  qp.E = mat2(1, 1, 2, 2);  // contradictory parallel equalities
  qp.f = vec({1, 3});
  EXPECT_EQ(solve_dual_active_set(qp).termination, QpTermination::kInfeasible);
  qp.f = vec({1, 2});  // consistent but redundant: fine
  const QpResult redundant = solve_dual_active_set(qp);
  ASSERT_EQ(redundant.termination, QpTermination::kOptimal);
  EXPECT_NEAR(redundant.x[0], 0.5, 1e-12);
  qp.G = mat2(1, 1, 1, 1);  // singular
  EXPECT_EQ(solve_dual_active_set(qp).termination, QpTermination::kNotConvex);
  qp.upper[0] = -1;  // below the lower bound
  EXPECT_THROW(solve_dual_active_set(qp), std::invalid_argument);
}

}  // namespace
}  // namespace chromo::calibration
