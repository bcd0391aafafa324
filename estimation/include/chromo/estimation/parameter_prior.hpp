#pragma once
// A prior over the skin parameters learned from real skin (issue 37): where a
// plan's channels barely determine all four parameters (the method's four
// channels against Cm, Ch, βm, Che: a thin gamut sheet, a second exact
// solution with Ch ×9 and βm −0.46 on part of skin), the estimate takes the
// parameters real skin has instead of any the channels allow.
//
// The statistic. Coordinates u = (ln Cm, ln Ch, βm, Che) (concentrations in
// logs, as the table's grid spaces them). From the 4D full-spectrum fits of
// training spectra (fit_spectrum: the NIST forearms of the other subjects),
// the mean μ and covariance S of u, S shrunk towards its diagonal with the
// Schäfer-Strimmer weight (as model_discrepancy.hpp) and each variance
// widened by `widen`² (a prior narrower than the training spread would
// over-trust 40-50 subjects); the penalty of parameters p is
//   (u(p) − μ)ᵀ S⁻¹ (u(p) − μ)
// added to the pixel's χ² (estimator.hpp, step 4b: the maximum a posteriori
// fit; flags and the model order still read the data's χ² alone).
//
// Thread rules: immutable; every function is reentrant.

#include <Eigen/Core>
#include <memory>
#include <span>

#include "chromo/estimation/skin_parameters.hpp"

namespace chromo::estimation {

class ParameterPrior {
 public:
  // From at least 5 parameter sets (std::invalid_argument otherwise, or for a
  // non-finite or non-positive Cm/Ch, or widen < 1).
  static ParameterPrior learn(std::span<const SkinParameters> fits, double widen = 1.0);
  // Learned from the 4D fits of every shipped NIST forearm
  // (nist_forearm_spectra(), fitted once per process).
  static std::shared_ptr<const ParameterPrior> standard();

  // u = (ln Cm, ln Ch, βm, Che).
  static Eigen::Vector4d coordinates(const SkinParameters& p);
  const Eigen::Vector4d& mean() const { return mean_; }            // μ in u
  const Eigen::Matrix4d& covariance() const { return covariance_; }  // S in u (shrunk, widened)
  const Eigen::Matrix4d& information() const { return information_; }  // S⁻¹
  double penalty(const SkinParameters& p) const;                   // (u − μ)ᵀ S⁻¹ (u − μ)
  int subjects() const { return subjects_; }
  double shrinkage() const { return shrinkage_; }

 private:
  Eigen::Vector4d mean_ = Eigen::Vector4d::Zero();
  Eigen::Matrix4d covariance_ = Eigen::Matrix4d::Identity(), information_ = Eigen::Matrix4d::Identity();
  int subjects_ = 0;
  double shrinkage_ = 0;
};

}  // namespace chromo::estimation
