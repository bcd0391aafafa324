#include "chromo/calibration/quadratic_program.hpp"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <Eigen/QR>
#include <cmath>
#include <limits>
#include <optional>
#include <stdexcept>
#include <vector>

namespace chromo::calibration {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

// One constraint nᵀx ≥ b (or = b), as the dual method sees it.
struct Constraint {
  Eigen::VectorXd normal;
  double bound = 0;
  bool equality = false;
  int variable = -1;  // for a bound: which variable
  int side = 0;       // for a bound: -1 lower, +1 upper
};

double feasibility_tolerance(const Eigen::VectorXd& x) {
  return 1e-9 * (1.0 + x.lpNorm<Eigen::Infinity>());
}

struct FaceSolution {
  Eigen::VectorXd x, equality_multiplier, bound_multiplier;
};

// The stationary point of the QP on the face where the variables with
// state ±1 sit at their lower/upper bound (state 0: free), with the
// equalities enforced. nullopt when the face admits no such point.
std::optional<FaceSolution> solve_face(const QuadraticProgram& qp, const Eigen::VectorXi& state) {
  const int n = static_cast<int>(qp.G.rows()), m = static_cast<int>(qp.E.rows());
  Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
  std::vector<int> free_vars;
  for (int i = 0; i < n; ++i) {
    if (state[i] < 0) x[i] = qp.lower[i];
    else if (state[i] > 0) x[i] = qp.upper[i];
    else free_vars.push_back(i);
  }
  const int k = static_cast<int>(free_vars.size());
  // Null-space method on the free variables: x_f = x_p + Z·y with E_f x_p =
  // f − E_F x_F and E_f Z = 0; y minimises the reduced (positive definite)
  // quadratic. Better conditioned than the full KKT matrix when G's entries
  // dwarf E's.
  Eigen::MatrixXd g_ff(k, k), e_f(m, k);
  Eigen::VectorXd gradient_fixed(k);  // of ½xᵀGx + aᵀx w.r.t. x_f, at x_f = 0
  const Eigen::VectorXd g_fixed = qp.G * x + qp.a;
  for (int r = 0; r < k; ++r) {
    for (int c = 0; c < k; ++c) g_ff(r, c) = qp.G(free_vars[r], free_vars[c]);
    for (int j = 0; j < m; ++j) e_f(j, r) = qp.E(j, free_vars[r]);
    gradient_fixed[r] = g_fixed[free_vars[r]];
  }
  const Eigen::VectorXd e_rhs = qp.f - qp.E * x;
  Eigen::VectorXd x_f = Eigen::VectorXd::Zero(k);
  Eigen::MatrixXd null_space = Eigen::MatrixXd::Identity(k, k);
  if (m > 0) {
    if (k == 0) {
      if (e_rhs.lpNorm<Eigen::Infinity>() > 1e-9 * (1.0 + qp.f.lpNorm<Eigen::Infinity>())) return std::nullopt;
      null_space.resize(0, 0);
    } else {
      const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr_t(e_f.transpose());  // E_fᵀ = Q R Pᵀ
      const Eigen::Index rank = qr_t.rank();
      x_f = Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd>(e_f).solve(e_rhs);
      if ((e_f * x_f - e_rhs).norm() > 1e-9 * (1.0 + e_rhs.norm())) return std::nullopt;  // inconsistent
      const Eigen::MatrixXd q = qr_t.householderQ() * Eigen::MatrixXd::Identity(k, k);
      null_space = q.rightCols(k - rank);
    }
  }
  if (null_space.cols() > 0) {
    const Eigen::MatrixXd reduced = null_space.transpose() * g_ff * null_space;
    const Eigen::LLT<Eigen::MatrixXd> llt(reduced);
    if (llt.info() != Eigen::Success) return std::nullopt;
    x_f -= null_space * llt.solve(null_space.transpose() * (g_ff * x_f + gradient_fixed));
  }
  for (int r = 0; r < k; ++r) x[free_vars[r]] = x_f[r];
  // Multipliers: least squares on the stationarity of the free variables.
  Eigen::VectorXd solution = Eigen::VectorXd::Zero(k + m);
  if (m > 0 && k > 0)
    solution.tail(m) = Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd>(e_f.transpose()).solve(g_ff * x_f + gradient_fixed);
  FaceSolution face{x, solution.tail(m), Eigen::VectorXd::Zero(n)};
  const Eigen::VectorXd stationarity = qp.G * x + qp.a - qp.E.transpose() * face.equality_multiplier;
  for (int i = 0; i < n; ++i)
    if (state[i] != 0) face.bound_multiplier[i] = stationarity[i];
  return face;
}

bool feasible(const QuadraticProgram& qp, const Eigen::VectorXd& x) {
  const double tol = feasibility_tolerance(x);
  for (int i = 0; i < x.size(); ++i)
    if (x[i] < qp.lower[i] - tol || x[i] > qp.upper[i] + tol) return false;
  return qp.E.rows() == 0 || (qp.E * x - qp.f).lpNorm<Eigen::Infinity>() <= tol * (1.0 + qp.f.lpNorm<Eigen::Infinity>());
}

QpResult finish(const QuadraticProgram& qp, QpResult result, const FaceSolution& face, const Eigen::VectorXi& state) {
  result.termination = QpTermination::kOptimal;
  result.x = face.x;
  result.objective = qp.objective(face.x);
  result.active_bound = state;
  result.equality_multiplier = face.equality_multiplier;
  result.bound_multiplier = face.bound_multiplier;
  return result;
}

}  // namespace

std::string QuadraticProgram::shape_error() const {
  const auto n = G.rows();
  if (n == 0 || G.cols() != n) return "G must be a non-empty square matrix";
  if (a.size() != n || lower.size() != n || upper.size() != n) return "a, lower and upper must have G's size";
  if (E.cols() != n && E.rows() != 0) return "E must have as many columns as G";
  if (f.size() != E.rows()) return "f must have one entry per row of E";
  if (G.hasNaN() || a.hasNaN() || E.hasNaN() || f.hasNaN() || lower.hasNaN() || upper.hasNaN()) return "NaN in the problem";
  for (Eigen::Index i = 0; i < n; ++i)
    if (lower[i] > upper[i]) return "lower bound above upper bound for variable " + std::to_string(i);
  return {};
}

const char* qp_termination_name(QpTermination termination) {
  switch (termination) {
    case QpTermination::kOptimal: return "optimal";
    case QpTermination::kInfeasible: return "infeasible";
    case QpTermination::kNotConvex: return "not_convex";
    case QpTermination::kIterationLimit: return "iteration_limit";
  }
  return "unknown";
}

QpResult solve_dual_active_set(const QuadraticProgram& qp, int max_iterations) {
  if (const std::string error = qp.shape_error(); !error.empty()) throw std::invalid_argument("QP: " + error);
  const int n = static_cast<int>(qp.G.rows()), m = static_cast<int>(qp.E.rows());
  QpResult result;
  const Eigen::LLT<Eigen::MatrixXd> llt(qp.G);
  if (llt.info() != Eigen::Success) {
    result.termination = QpTermination::kNotConvex;
    return result;
  }
  const Eigen::MatrixXd l_inverse =
      llt.matrixL().solve(Eigen::MatrixXd::Identity(n, n));  // L⁻¹ with G = L Lᵀ

  std::vector<Constraint> constraints;
  for (int j = 0; j < m; ++j) constraints.push_back({qp.E.row(j).transpose(), qp.f[j], true, -1, 0});
  for (int i = 0; i < n; ++i) {
    if (std::isfinite(qp.lower[i])) constraints.push_back({Eigen::VectorXd::Unit(n, i), qp.lower[i], false, i, -1});
    if (std::isfinite(qp.upper[i])) constraints.push_back({-Eigen::VectorXd::Unit(n, i), -qp.upper[i], false, i, +1});
  }

  Eigen::VectorXd x = -llt.solve(qp.a);  // unconstrained minimum
  std::vector<int> active;               // indices into constraints
  std::vector<double> sign;              // +1, or -1 for an equality approached from above
  std::vector<double> multiplier;        // dual variables of the active constraints (≥ 0 for inequalities)
  std::vector<bool> in_active(constraints.size(), false);
  int next_equality = 0;

  while (true) {
    // Step 1: the constraint to add: the next equality, else the most violated bound.
    int p = -1;
    double p_sign = 1.0;
    if (next_equality < m) {
      p = next_equality++;
      p_sign = constraints[p].normal.dot(x) - constraints[p].bound > 0 ? -1.0 : 1.0;
    } else {
      double worst = -feasibility_tolerance(x);
      for (int j = m; j < static_cast<int>(constraints.size()); ++j) {
        if (in_active[j]) continue;
        const double slack = constraints[j].normal.dot(x) - constraints[j].bound;
        if (slack < worst) worst = slack, p = j;
      }
      if (p < 0) break;  // every constraint holds: x is optimal
    }
    const Eigen::VectorXd np = p_sign * constraints[p].normal;
    const double bp = p_sign * constraints[p].bound;
    double p_multiplier = 0.0;

    // Step 2: move in the primal (z) and dual (r) directions until p holds.
    while (true) {
      if (++result.iterations > max_iterations) {
        result.termination = QpTermination::kIterationLimit;
        result.x = x;
        result.objective = qp.objective(x);
        return result;
      }
      const int q = static_cast<int>(active.size());
      Eigen::MatrixXd normals(n, q);
      for (int i = 0; i < q; ++i) normals.col(i) = sign[i] * constraints[active[i]].normal;
      const Eigen::HouseholderQR<Eigen::MatrixXd> qr(l_inverse * normals);
      const Eigen::MatrixXd q_full = qr.householderQ() * Eigen::MatrixXd::Identity(n, n);
      const Eigen::VectorXd d = q_full.transpose() * (l_inverse * np);
      const Eigen::VectorXd z = l_inverse.transpose() * (q_full.rightCols(n - q) * d.tail(n - q));
      const Eigen::VectorXd r =
          qr.matrixQR().topLeftCorner(q, q).triangularView<Eigen::Upper>().solve(d.head(q));

      double t1 = kInfinity;  // largest dual step keeping the active multipliers ≥ 0
      int drop = -1;
      for (int i = 0; i < q; ++i) {
        if (constraints[active[i]].equality || r[i] <= 0) continue;
        if (const double t = multiplier[i] / r[i]; t < t1) t1 = t, drop = i;
      }
      const double slack = np.dot(x) - bp;
      const bool dependent = d.tail(n - q).squaredNorm() <= 1e-20 * d.squaredNorm();
      if (dependent && constraints[p].equality) {
        // Linearly dependent on the equalities already active: redundant if it holds, else contradictory.
        if (std::abs(slack) <= feasibility_tolerance(x) * (1.0 + std::abs(bp))) break;
        result.termination = QpTermination::kInfeasible;
        return result;
      }
      const double t2 = dependent ? kInfinity : -slack / z.dot(np);  // full primal step
      const double t = std::min(t1, t2);
      if (!std::isfinite(t)) {
        result.termination = QpTermination::kInfeasible;
        return result;
      }
      for (int i = 0; i < q; ++i) multiplier[i] -= t * r[i];
      p_multiplier += t;
      if (std::isfinite(t2)) x += t * z;
      if (t2 <= t1) {
        active.push_back(p), sign.push_back(p_sign), multiplier.push_back(p_multiplier);
        in_active[p] = true;
        break;
      }
      in_active[active[drop]] = false;
      active.erase(active.begin() + drop), sign.erase(sign.begin() + drop), multiplier.erase(multiplier.begin() + drop);
    }
  }

  // Polish: solve the KKT system of the final active set exactly (removes the
  // rounding accumulated along the steps) and report its multipliers.
  Eigen::VectorXi state = Eigen::VectorXi::Zero(n);
  for (int j : active)
    if (!constraints[j].equality) state[constraints[j].variable] = constraints[j].side;
  if (const auto face = solve_face(qp, state); face && feasible(qp, face->x)) return finish(qp, result, *face, state);
  FaceSolution face{x, Eigen::VectorXd::Zero(m), Eigen::VectorXd::Zero(n)};
  for (std::size_t i = 0; i < active.size(); ++i) {
    const Constraint& c = constraints[active[i]];
    if (c.equality) face.equality_multiplier[active[i]] = sign[i] * multiplier[i];
    else face.bound_multiplier[c.variable] = -c.side * multiplier[i];
  }
  return finish(qp, result, face, state);
}

QpResult solve_by_enumeration(const QuadraticProgram& qp) {
  if (const std::string error = qp.shape_error(); !error.empty()) throw std::invalid_argument("QP: " + error);
  const int n = static_cast<int>(qp.G.rows());
  QpResult result;
  if (Eigen::LLT<Eigen::MatrixXd>(qp.G).info() != Eigen::Success) {
    result.termination = QpTermination::kNotConvex;
    return result;
  }
  Eigen::VectorXi state = Eigen::VectorXi::Constant(n, -1);
  std::optional<FaceSolution> best;
  Eigen::VectorXi best_state;
  double best_objective = kInfinity;
  while (true) {
    bool valid = true;
    for (int i = 0; i < n; ++i)
      if ((state[i] < 0 && !std::isfinite(qp.lower[i])) || (state[i] > 0 && !std::isfinite(qp.upper[i]))) valid = false;
    if (valid) {
      ++result.iterations;
      if (auto face = solve_face(qp, state); face && feasible(qp, face->x)) {
        if (const double value = qp.objective(face->x); value < best_objective)
          best_objective = value, best = std::move(face), best_state = state;
      }
    }
    int i = 0;  // next state in base 3
    while (i < n && state[i] == 1) state[i++] = -1;
    if (i == n) break;
    ++state[i];
  }
  if (!best) return result;  // kInfeasible
  return finish(qp, result, *best, best_state);
}

}  // namespace chromo::calibration
