#include "plan_model.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace chromo::planning {

PlanModel::PlanModel(const PlanDescription& plan, const calibration::LedLibrary& library, const CameraNoise& camera)
    : camera_(camera), dark_frames_(plan.dark_frames) {
  if (camera_.sensitivity.name.empty()) camera_.sensitivity = spectral::builtin_camera("nikon_d5100");
  std::array<spectral::Spectrum, spectral::kLedTypeCount> per_drive;
  for (int t = 0; t < spectral::kLedTypeCount; ++t) per_drive[t] = library.leds[t].spectrum_per_unit_drive();
  const double rho = camera_.white_reflectance;
  green_norm_ = camera_.sensitivity.rgb[1].values().sum() * spectral::kGridStepNm;
  for (std::size_t k = 0; k < plan.captures.size(); ++k) {
    const PlannedCapture& c = plan.captures[k];
    spectral::Spectrum light;
    for (int t = 0; t < spectral::kLedTypeCount; ++t) light += per_drive[t] * c.drive[t];
    Eigen::Matrix<double, 3, spectral::kGridSize> r;
    for (int ch = 0; ch < 3; ++ch)
      r.row(ch) = (camera_.sensitivity.rgb[ch].values() * light.values()).matrix().transpose() * spectral::kGridStepNm;
    const Eigen::Vector3d white = r.rowwise().sum();
    if (!(white.maxCoeff() > 0))
      throw std::invalid_argument("plan: captures[" + std::to_string(k) + "] ('" + c.name +
                                  "'): the camera sees no light of its drive levels in this library");
    response_.push_back(r);
    light_.push_back(light);
    white_response_.push_back(white);
    electrons_per_response_.push_back(c.white_fill * camera_.full_well_e / (rho * white.maxCoeff()));
    frames_.push_back(c.frames);
    white_frames_.push_back(c.white_frames);
  }
  const std::vector<PlannedChannel> channels = plan.effective_channels();
  weights_.resize(static_cast<Eigen::Index>(channels.size()), spectral::kGridSize);
  for (std::size_t i = 0; i < channels.size(); ++i) {
    Channel channel;
    channel.camera_channel = channels[i].camera_channel;
    channel.terms.push_back({plan.capture_index(channels[i].capture), 1.0});
    if (!channels[i].minus.empty()) channel.terms.push_back({plan.capture_index(channels[i].minus), -1.0});
    Eigen::Matrix<double, 1, spectral::kGridSize> row = Eigen::Matrix<double, 1, spectral::kGridSize>::Zero();
    double white = 0, brightest = 0;
    for (const Term& t : channel.terms) {
      row += t.sign * response_[t.capture].row(channel.camera_channel);
      white += t.sign * white_response_[t.capture][channel.camera_channel];
      brightest = std::max(brightest, white_response_[t.capture][channel.camera_channel]);
    }
    // A channel whose white signal is (nearly) nothing is no measurement.
    if (!(white > 1e-6 * brightest) || !(brightest > 0))
      throw std::invalid_argument("plan: channels[" + std::to_string(i) + "] ('" + channels[i].name() +
                                  "'): its white reference gives no signal");
    weights_.row(static_cast<Eigen::Index>(i)) = row / white;
    channels_.push_back(std::move(channel));
    channel_names_.push_back(channels[i].name());
  }
}

estimation::MeasurementSet PlanModel::measurement_set() const {
  estimation::MeasurementSet set;
  set.camera = camera_.sensitivity;
  for (std::size_t i = 0; i < channels_.size(); ++i) {
    estimation::MeasurementChannel c;
    c.name = channel_names_[i];
    c.camera_channel = channels_[i].camera_channel;
    c.illuminant = spectral::Spectrum::constant(0.0);
    for (const Term& t : channels_[i].terms) c.illuminant += light_[t.capture] * t.sign;
    set.channels.push_back(std::move(c));
  }
  return set;
}

double PlanModel::exposure_us(int capture) const {
  return electrons_per_response_[capture] * green_norm_ / camera_.quantum_scale_e_per_us;
}

Eigen::VectorXd PlanModel::values(const spectral::Spectrum& albedo) const {
  return weights_ * albedo.values().matrix();
}

Eigen::MatrixXd PlanModel::covariance(const spectral::Spectrum& albedo) const {
  const int captures = capture_count();
  const double rho = camera_.white_reflectance;
  const double step = camera_.electrons_per_dn();
  const double floor = camera_.read_noise_e * camera_.read_noise_e + step * step / 12;
  // Raw quantities: subject S(k, c) at 3k + c, white W(k, c) at 3K + 3k + c, dark D(c) at 6K + c.
  const int raw = 6 * captures + 3;
  Eigen::VectorXd variance(raw);
  for (int k = 0; k < captures; ++k) {
    const Eigen::Vector3d subject = electrons_per_response_[k] * (response_[k] * albedo.values().matrix());
    const Eigen::Vector3d white = electrons_per_response_[k] * rho * white_response_[k];
    for (int c = 0; c < 3; ++c) {
      variance[3 * k + c] = (std::max(subject[c], 0.0) + floor) / frames_[k];
      variance[3 * captures + 3 * k + c] = (white[c] + floor) / white_frames_[k];
    }
  }
  for (int c = 0; c < 3; ++c) variance[6 * captures + c] = floor / dark_frames_;

  const Eigen::VectorXd v = values(albedo);
  Eigen::MatrixXd gradient = Eigen::MatrixXd::Zero(channel_count(), raw);
  for (int i = 0; i < channel_count(); ++i) {
    const Channel& ch = channels_[i];
    const int c = ch.camera_channel;
    double den = 0, inverse_k_sum = 0;  // den = Σ c_j (W_j − D)/K_j = Σ c_j ρ R_j(1)
    for (const Term& t : ch.terms) {
      den += t.sign * rho * white_response_[t.capture][c];
      inverse_k_sum += t.sign / electrons_per_response_[t.capture];
    }
    for (const Term& t : ch.terms) {
      const double k = electrons_per_response_[t.capture];
      gradient(i, 3 * t.capture + c) += rho * t.sign / (k * den);
      gradient(i, 3 * captures + 3 * t.capture + c) += -v[i] * t.sign / (k * den);
    }
    gradient(i, 6 * captures + c) += (v[i] - rho) * inverse_k_sum / den;
  }
  return gradient * variance.asDiagonal() * gradient.transpose();
}

Eigen::VectorXd PlanModel::simulate(const spectral::Spectrum& albedo, std::mt19937_64& rng) const {
  std::normal_distribution<double> normal;
  const double step = camera_.electrons_per_dn();
  const double max_dn = (1 << camera_.adc_bits) - 1;
  auto frame_mean_dn = [&](double electrons, int frames) {
    double sum = 0;
    for (int f = 0; f < frames; ++f) {
      double e = electrons + std::sqrt(std::max(electrons, 0.0)) * normal(rng);
      e = std::clamp(e, 0.0, camera_.full_well_e) + camera_.read_noise_e * normal(rng);
      sum += std::clamp(std::round(camera_.black_level_dn + e / step), 0.0, max_dn);
    }
    return sum / frames;
  };
  const int captures = capture_count();
  const double rho = camera_.white_reflectance;
  std::vector<Eigen::Vector3d> subject(captures), white(captures);
  Eigen::Vector3d dark;
  for (int c = 0; c < 3; ++c) dark[c] = frame_mean_dn(0.0, dark_frames_);
  for (int k = 0; k < captures; ++k) {
    const Eigen::Vector3d s = electrons_per_response_[k] * (response_[k] * albedo.values().matrix());
    const Eigen::Vector3d w = electrons_per_response_[k] * rho * white_response_[k];
    for (int c = 0; c < 3; ++c) {
      subject[k][c] = frame_mean_dn(s[c], frames_[k]);
      white[k][c] = frame_mean_dn(w[c], white_frames_[k]);
    }
  }
  Eigen::VectorXd v(channel_count());
  for (int i = 0; i < channel_count(); ++i) {
    const Channel& ch = channels_[i];
    const int c = ch.camera_channel;
    double num = 0, den = 0;
    for (const Term& t : ch.terms) {
      num += t.sign * (subject[t.capture][c] - dark[c]) / electrons_per_response_[t.capture];
      den += t.sign * (white[t.capture][c] - dark[c]) / electrons_per_response_[t.capture];
    }
    v[i] = rho * num / den;
  }
  return v;
}

}  // namespace chromo::planning
