#include "chromo/maps/external_maps.hpp"

#include <omp.h>

#include <Eigen/Cholesky>
#include <opencv2/imgcodecs.hpp>
#include <algorithm>
#include <chrono>
#include <functional>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>

#include "chromo/estimation/channel_buffer.hpp"
#include "chromo/files/bounded_read.hpp"
#include "chromo/files/float_image.hpp"
#include "chromo/maps/relight.hpp"

namespace chromo::maps {
namespace fs = std::filesystem;
namespace {

std::vector<float> read_grey(const fs::path& path, const std::string& what, int* width, int* height) {
  if (path.extension() == ".exr") {
    files::FloatImage image;
    try {
      image = files::read_exr(path);
    } catch (const files::ImageError& e) {
      throw std::invalid_argument(what + ": " + e.what());
    }
    if (image.channels.empty()) throw std::invalid_argument(what + ": " + path.string() + ": has no channels");
    const auto y = std::find(image.channel_names.begin(), image.channel_names.end(), "Y");
    *width = image.width, *height = image.height;
    return image.channels[y == image.channel_names.end() ? 0 : y - image.channel_names.begin()];
  }
  cv::Mat grey;
  std::string bytes;
  try {
    bytes = files::read_png_file(path);  // a regular PNG file, size checked by header before decoding
  } catch (const files::InputFileError& e) {
    throw std::invalid_argument(what + ": " + e.what());
  }
  try {
    grey = cv::imdecode(cv::Mat(1, static_cast<int>(bytes.size()), CV_8U, bytes.data()),
                        cv::IMREAD_GRAYSCALE | cv::IMREAD_ANYDEPTH);
  } catch (const cv::Exception&) {
  }
  if (grey.empty()) throw std::invalid_argument(what + ": " + path.string() + ": not a readable image");
  cv::Mat f;
  grey.convertTo(f, CV_32F);
  *width = f.cols, *height = f.rows;
  return {f.ptr<float>(), f.ptr<float>() + f.total()};
}

// Pool-adjacent-violators for a non-decreasing fit of y (weights w).
std::vector<double> isotonic_increasing(const std::vector<double>& y, const std::vector<double>& w) {
  struct Block {
    double sum_wy, sum_w;
    std::size_t count;
  };
  std::vector<Block> blocks;
  for (std::size_t i = 0; i < y.size(); ++i) {
    blocks.push_back({w[i] * y[i], w[i], 1});
    while (blocks.size() > 1) {
      const Block& b = blocks.back();
      const Block& a = blocks[blocks.size() - 2];
      if (a.sum_wy / a.sum_w <= b.sum_wy / b.sum_w) break;
      const Block merged{a.sum_wy + b.sum_wy, a.sum_w + b.sum_w, a.count + b.count};
      blocks.pop_back();
      blocks.back() = merged;
    }
  }
  std::vector<double> fit;
  for (const Block& b : blocks) fit.insert(fit.end(), b.count, b.sum_wy / b.sum_w);
  return fit;
}

ParameterMaps empty_maps(int width, int height) {
  const std::size_t n = static_cast<std::size_t>(width) * height;
  return {width, height, std::vector<float>(n, 0.0f), std::vector<float>(n, 0.0f), std::vector<float>(n, 0.0f),
          std::vector<float>(n, 0.0f), std::vector<float>(n, 0.0f)};
}

bool measurable(estimation::PixelFlag flag) {
  return flag != estimation::PixelFlag::kNonFinite && flag != estimation::PixelFlag::kSaturated && flag != estimation::PixelFlag::kDark &&
         !estimation::outside_the_skin(flag);
}

// The augmented per-pixel fit (header): χ² of the measurement plus the prior
// on grid coordinates 0 (Cm) and 1 (Ch), Levenberg-Marquardt within the grid box.
class PriorFit {
 public:
  PriorFit(const estimation::ForwardTable& table, double prior_sigma_log10, int iterations)
      : table_(table), iterations_(iterations) {
    for (int axis = 0; axis < 2; ++axis) {
      const double log_step = std::log10(table.node_value(axis, 1) / table.node_value(axis, 0));
      sigma_grid_[axis] = prior_sigma_log10 / log_step;
    }
  }

  estimation::GridPoint fit(const double* measured, const double* weight, double prior_x0, double prior_x1) const {
    const int channels = table_.channels();
    const auto nodes = table_.nodes();
    estimation::GridPoint best{prior_x0, prior_x1, 0, 0};
    double best_cost = std::numeric_limits<double>::infinity();
    for (int b = 0; b < nodes[2]; b += 2)
      for (int c = 0; c < nodes[3]; c += 2) {
        const estimation::GridPoint x{prior_x0, prior_x1, double(b), double(c)};
        const double cost = this->cost(x, measured, weight, prior_x0, prior_x1);
        if (cost < best_cost) best_cost = cost, best = x;
      }
    Eigen::VectorXd r = Eigen::VectorXd::Zero(channels + 2);
    Eigen::Matrix<double, Eigen::Dynamic, 4> J(channels + 2, 4);
    estimation::ChannelBuffer<double> value(channels), jacobian(std::size_t(channels) * 4);
    double lambda = 1e-3;
    estimation::GridPoint x = best;
    double cost = best_cost;
    for (int it = 0; it < iterations_; ++it) {
      table_.predict(x, value, jacobian);
      J.setZero();
      for (int ch = 0; ch < channels; ++ch) {
        r[ch] = (value[ch] - measured[ch]) * weight[ch];
        for (int k = 0; k < 4; ++k) J(ch, k) = jacobian[ch * 4 + k] * weight[ch];
      }
      r[channels] = (x[0] - prior_x0) / sigma_grid_[0];
      r[channels + 1] = (x[1] - prior_x1) / sigma_grid_[1];
      J(channels, 0) = 1.0 / sigma_grid_[0];
      J(channels + 1, 1) = 1.0 / sigma_grid_[1];
      const Eigen::Matrix4d JtJ = J.transpose() * J;
      const Eigen::Vector4d g = J.transpose() * r;
      bool improved = false;
      for (int attempt = 0; attempt < 8 && !improved; ++attempt) {
        Eigen::Matrix4d A = JtJ;
        A.diagonal() += lambda * (JtJ.diagonal().array() + 1e-9).matrix();
        const Eigen::Vector4d step = A.ldlt().solve(-g);
        estimation::GridPoint trial;
        for (int k = 0; k < 4; ++k) trial[k] = std::clamp(x[k] + step[k], 0.0, double(nodes[k] - 1));
        const double trial_cost = this->cost(trial, measured, weight, prior_x0, prior_x1);
        if (trial_cost < cost) {
          const double gain = cost - trial_cost;
          x = trial, cost = trial_cost, lambda = std::max(lambda / 4, 1e-9), improved = true;
          if (gain < 1e-10 * (1 + cost)) return x;
        } else {
          lambda *= 8;
        }
      }
      if (!improved) break;
    }
    return x;
  }

 private:
  double cost(const estimation::GridPoint& x, const double* measured, const double* weight, double p0, double p1) const {
    estimation::ChannelBuffer<double> value(table_.channels());
    table_.predict(x, value);
    double sum = 0;
    for (int c = 0; c < table_.channels(); ++c) sum += std::pow((value[c] - measured[c]) * weight[c], 2);
    return sum + std::pow((x[0] - p0) / sigma_grid_[0], 2) + std::pow((x[1] - p1) / sigma_grid_[1], 2);
  }
  const estimation::ForwardTable& table_;
  int iterations_;
  double sigma_grid_[2] = {1, 1};
};

void set_pixel(ParameterMaps& maps, std::size_t i, const estimation::SkinParameters& p) {
  maps.cm[i] = static_cast<float>(p.cm), maps.ch[i] = static_cast<float>(p.ch);
  maps.bm[i] = static_cast<float>(p.bm), maps.che[i] = static_cast<float>(p.che);
}

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

}  // namespace

ExternalMaps read_external_maps(const fs::path& melanin, const fs::path& hemoglobin) {
  ExternalMaps out;
  int w2 = 0, h2 = 0;
  out.melanin = read_grey(melanin, "melanin", &out.width, &out.height);
  out.hemoglobin = read_grey(hemoglobin, "hemoglobin", &w2, &h2);
  if (w2 != out.width || h2 != out.height)
    throw std::invalid_argument("hemoglobin: " + hemoglobin.string() + " is " + std::to_string(w2) + "x" +
                                std::to_string(h2) + " but the melanin map is " + std::to_string(out.width) + "x" +
                                std::to_string(out.height));
  return out;
}

double MonotoneMapping::log10_at(double value) const {
  if (input.empty()) return std::numeric_limits<double>::quiet_NaN();
  if (value <= input.front()) return output_log10.front();
  if (value >= input.back()) return output_log10.back();
  const std::size_t k = std::upper_bound(input.begin(), input.end(), value) - input.begin();
  const double t = (value - input[k - 1]) / (input[k] - input[k - 1]);
  return output_log10[k - 1] + t * (output_log10[k] - output_log10[k - 1]);
}

namespace {

// Quantile bins of the finite inputs (equal inputs never straddle two bins),
// in increasing order of input.
struct Bins {
  std::vector<double> centre;                  // mean input per bin
  std::vector<std::vector<std::size_t>> members;
};
Bins quantile_bins(std::span<const double> input, std::span<const double> target, int bins) {
  if (input.size() != target.size()) throw std::invalid_argument("monotone mapping: input and target sizes differ");
  if (bins < 2) throw std::invalid_argument("monotone mapping: at least 2 bins");
  std::vector<std::size_t> order;
  for (std::size_t i = 0; i < input.size(); ++i)
    if (std::isfinite(input[i]) && std::isfinite(target[i])) order.push_back(i);
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return input[a] < input[b]; });
  if (order.empty() || input[order.front()] == input[order.back()])
    throw std::invalid_argument("monotone mapping: the imported map has fewer than 2 distinct values");
  Bins out;
  const std::size_t per_bin = std::max<std::size_t>(1, order.size() / bins);
  for (std::size_t start = 0; start < order.size();) {
    std::size_t end = std::min(order.size(), start + per_bin);
    while (end < order.size() && input[order[end]] == input[order[end - 1]]) ++end;
    double sum = 0;
    for (std::size_t k = start; k < end; ++k) sum += input[order[k]];
    out.centre.push_back(sum / (end - start));
    out.members.emplace_back(order.begin() + start, order.begin() + end);
    start = end;
  }
  return out;
}

// Generalised pool-adjacent-violators: bin k's loss over candidate values is
// loss[k][v]; a block of pooled bins takes the candidate minimising the sum of
// its bins' losses; pooling continues until the chosen candidates are
// non-decreasing. Returns the candidate index per bin and the total loss.
std::vector<int> isotonic_argmin(const std::vector<std::vector<double>>& loss, double* total) {
  struct Block {
    std::vector<double> loss;
    int best;
    std::size_t count;
  };
  auto argmin = [](const std::vector<double>& v) { return static_cast<int>(std::min_element(v.begin(), v.end()) - v.begin()); };
  std::vector<Block> blocks;
  for (const auto& row : loss) {
    blocks.push_back({row, argmin(row), 1});
    while (blocks.size() > 1 && blocks[blocks.size() - 2].best > blocks.back().best) {
      Block top = std::move(blocks.back());
      blocks.pop_back();
      Block& below = blocks.back();
      for (std::size_t v = 0; v < below.loss.size(); ++v) below.loss[v] += top.loss[v];
      below.best = argmin(below.loss), below.count += top.count;
    }
  }
  std::vector<int> out;
  *total = 0;
  for (const Block& b : blocks) out.insert(out.end(), b.count, b.best), *total += b.loss[b.best];
  return out;
}

}  // namespace

MonotoneMapping fit_monotone_mapping(std::span<const double> input, std::span<const double> target, int bins,
                                     MonotoneDirection direction) {
  const Bins b = quantile_bins(input, target, bins);
  // Bin value: the median target (robust to pixels the 2D model cannot
  // explain, which sit at the edges of the range), weighted by pixel count.
  std::vector<double> y, w;
  for (const auto& members : b.members) {
    std::vector<double> targets;
    for (std::size_t i : members) targets.push_back(target[i]);
    std::nth_element(targets.begin(), targets.begin() + targets.size() / 2, targets.end());
    y.push_back(targets[targets.size() / 2]), w.push_back(double(members.size()));
  }
  std::vector<double> negated(y.size());
  std::transform(y.begin(), y.end(), negated.begin(), [](double v) { return -v; });
  const std::vector<double> up = isotonic_increasing(y, w);
  std::vector<double> down = isotonic_increasing(negated, w);
  for (double& v : down) v = -v;
  auto sse = [&](const std::vector<double>& fit) {
    double s = 0;
    for (std::size_t k = 0; k < y.size(); ++k) s += w[k] * (fit[k] - y[k]) * (fit[k] - y[k]);
    return s;
  };
  MonotoneMapping mapping;
  mapping.increasing = direction == MonotoneDirection::kEither ? sse(up) <= sse(down)
                                                               : direction == MonotoneDirection::kIncreasing;
  mapping.input = b.centre;
  mapping.output_log10 = mapping.increasing ? up : down;
  return mapping;
}

MonotoneMapping fit_monotone_mapping_to_loss(std::span<const double> input, int bins, const std::vector<double>& candidates_log10,
                                             const std::function<double(std::size_t item, double value_log10)>& loss,
                                             MonotoneDirection direction) {
  const std::vector<double> no_target(input.size(), 0.0);
  const Bins b = quantile_bins(input, no_target, bins);
  const int nb = static_cast<int>(b.members.size()), nv = static_cast<int>(candidates_log10.size());
  std::vector<std::vector<double>> table(nb, std::vector<double>(nv, 0.0));
#pragma omp parallel for schedule(dynamic, 1)
  for (int k = 0; k < nb; ++k)
    for (int v = 0; v < nv; ++v)
      for (std::size_t i : b.members[k]) table[k][v] += loss(i, candidates_log10[v]);
  double loss_up = 0, loss_down = 0;
  const std::vector<int> up = isotonic_argmin(table, &loss_up);
  std::vector<std::vector<double>> reversed(table.rbegin(), table.rend());
  std::vector<int> down = isotonic_argmin(reversed, &loss_down);
  std::reverse(down.begin(), down.end());
  MonotoneMapping mapping;
  mapping.increasing = direction == MonotoneDirection::kEither ? loss_up <= loss_down
                                                               : direction == MonotoneDirection::kIncreasing;
  mapping.input = b.centre;
  for (int k = 0; k < nb; ++k) mapping.output_log10.push_back(candidates_log10[(mapping.increasing ? up : down)[k]]);
  return mapping;
}

bool ImportOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& message) {
    if (error) *error = message;
    return false;
  };
  if (!(prior_sigma_log10 > 0) || !std::isfinite(prior_sigma_log10)) return fail("prior_sigma_log10: must be > 0");
  if (mapping_bins < 2 || mapping_bins > 4096) return fail("mapping_bins: must be 2-4096");
  if (search_4d != estimation::InverterMethod::kFast && search_4d != estimation::InverterMethod::kExhaustive)
    return fail("search_4d: must be fast or exhaustive");
  if (augment_iterations < 1 || augment_iterations > 200) return fail("augment_iterations: must be 1-200");
  if (threads < 0) return fail("threads: must be ≥ 0");
  return true;
}

namespace {

// The measurement's photograph (images[0], with R, G and B), once the options and sizes are checked.
const session::MeasurementImage& checked_import(const ExternalMaps& external, const session::MeasurementFile& m,
                                                const ImportOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument(error);
  if (external.width != m.width || external.height != m.height)
    throw std::invalid_argument("melanin/hemoglobin maps are " + std::to_string(external.width) + "x" +
                                std::to_string(external.height) + " but the measurement is " +
                                std::to_string(m.width) + "x" + std::to_string(m.height));
  if (!options.statistics_mask.empty() && options.statistics_mask.size() != static_cast<std::size_t>(m.width) * m.height)
    throw std::invalid_argument("statistics_mask: not the measurement's size");
  const session::MeasurementImage& photo = m.images.front();
  for (const char* c : {"R", "G", "B"})
    if (std::find(photo.channels.begin(), photo.channels.end(), c) == photo.channels.end())
      throw std::invalid_argument("measurement: images[0] (" + photo.name +
                                  ") must list channels R, G and B: it is the photograph of the comparison");
  return photo;
}

// The compared pixels (measurable in the 4D fit, finite imported values):
// where they are, the imported values, the 2D inversion's log10 Cm and Ch,
// and the measurement with the estimator's weights (camera noise + the
// table's model error), `channels` per pixel.
struct ComparedPixels {
  std::vector<std::size_t> where;
  std::vector<double> melanin, hemoglobin, log_cm, log_ch, values, weights;
};
ComparedPixels compared_pixels(const ExternalMaps& external, const estimation::MeasurementSet& set,
                               std::span<const float> measured, std::span<const estimation::PixelEstimate> fit4,
                               std::span<const estimation::PixelEstimate> fit2, std::vector<std::uint8_t>& compared) {
  const int channels = set.size();
  const double sigma_model = estimation::EstimatorOptions{}.model_sigma_relative;
  compared.assign(fit4.size(), 0);
  ComparedPixels out;
  for (std::size_t i = 0; i < fit4.size(); ++i) {
    if (!measurable(fit4[i].flag) || !std::isfinite(external.melanin[i]) || !std::isfinite(external.hemoglobin[i]))
      continue;
    compared[i] = 1;
    out.where.push_back(i);
    out.melanin.push_back(external.melanin[i]), out.hemoglobin.push_back(external.hemoglobin[i]);
    out.log_cm.push_back(std::log10(fit2[i].parameters.cm)), out.log_ch.push_back(std::log10(fit2[i].parameters.ch));
    for (int c = 0; c < channels; ++c) {
      const double a = measured[i * channels + c];
      out.values.push_back(a);
      out.weights.push_back(1.0 / std::sqrt(set.channels[c].noise.variance(a) + std::pow(sigma_model * std::max(a, 0.0), 2)));
    }
  }
  return out;
}

// The two mappings: isotonic regression on the per-pixel 2D inversion; then
// the bins' values refitted to the measurement's χ² in the 2D model (two
// rounds, each axis with the other's current mapping).
void fit_mappings(const ComparedPixels& p, const estimation::ForwardTable& table, int channels,
                  const ImportOptions& options, ImportResult& result) {
  try {
    result.cm_mapping = fit_monotone_mapping(p.melanin, p.log_cm, options.mapping_bins, options.direction);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("melanin: ") + e.what());
  }
  try {
    result.ch_mapping = fit_monotone_mapping(p.hemoglobin, p.log_ch, options.mapping_bins, options.direction);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("hemoglobin: ") + e.what());
  }
  auto candidates = [](const estimation::ParameterRange& range) {
    std::vector<double> out;
    const double lo = std::log10(range.min), hi = std::log10(range.max);
    for (int k = 0; k <= 120; ++k) out.push_back(lo + (hi - lo) * k / 120.0);
    return out;
  };
  auto chi2_2d = [&](std::size_t item, double log_cm_value, double log_ch_value) {
    estimation::ChannelBuffer<double> predicted(table.channels());
    table.predict(table.to_grid({std::pow(10.0, log_cm_value), std::pow(10.0, log_ch_value), 0.7, 0.0}), predicted);
    double sum = 0;
    for (int c = 0; c < channels; ++c)
      sum += std::pow((predicted[c] - p.values[item * channels + c]) * p.weights[item * channels + c], 2);
    return 25.0 * std::log1p(sum / 25.0);  // robust: see the header
  };
  for (int round = 0; round < 2; ++round) {
    result.ch_mapping = fit_monotone_mapping_to_loss(p.hemoglobin, options.mapping_bins, candidates(estimation::kChRange),
                                                     [&](std::size_t item, double v) {
                                                       return chi2_2d(item, result.cm_mapping.log10_at(p.melanin[item]), v);
                                                     }, options.direction);
    result.cm_mapping = fit_monotone_mapping_to_loss(p.melanin, options.mapping_bins, candidates(estimation::kCmRange),
                                                     [&](std::size_t item, double v) {
                                                       return chi2_2d(item, v, result.ch_mapping.log10_at(p.hemoglobin[item]));
                                                     }, options.direction);
  }
}

// The 4D search's maps as fitted, and the 2D mapping's: the mapped imported
// values where compared, flag 1 (or the 4D flag) elsewhere.
void fill_4d_and_mapped(const ExternalMaps& external, std::span<const estimation::PixelEstimate> fit4, int width,
                        int height, ImportResult& result) {
  result.mapped_2d = {"2D mapping", empty_maps(width, height), {}, {}, {}};
  result.augmented = {"augmented", empty_maps(width, height), {}, {}, {}};
  result.search_4d = {"4D search", empty_maps(width, height), {}, {}, {}};
  for (std::size_t i = 0; i < fit4.size(); ++i) {
    const float flag = static_cast<float>(static_cast<int>(fit4[i].flag));
    result.search_4d.maps.flags[i] = flag;
    set_pixel(result.search_4d.maps, i, fit4[i].parameters);
    if (!result.compared[i]) {
      result.mapped_2d.maps.flags[i] = result.augmented.maps.flags[i] = measurable(fit4[i].flag) ? 1.0f : flag;
      continue;
    }
    const estimation::SkinParameters mapped{std::clamp(std::pow(10.0, result.cm_mapping.log10_at(external.melanin[i])), estimation::kCmRange.min, estimation::kCmRange.max),
                                std::clamp(std::pow(10.0, result.ch_mapping.log10_at(external.hemoglobin[i])), estimation::kChRange.min, estimation::kChRange.max),
                                0.7, 0.0};
    set_pixel(result.mapped_2d.maps, i, mapped);
  }
}

// Augmented: the prior fit per compared pixel, starting from the 2D mapping.
void fit_augmented(const ComparedPixels& p, const estimation::ForwardTable& table, int channels,
                   const ImportOptions& options, ImportResult& result) {
  const PriorFit prior_fit(table, options.prior_sigma_log10, options.augment_iterations);
  const long long n = static_cast<long long>(p.where.size());
#pragma omp parallel for schedule(dynamic, 256) num_threads(options.threads > 0 ? options.threads : omp_get_max_threads())
  for (long long item = 0; item < n; ++item) {
    const std::size_t i = p.where[item];
    const estimation::GridPoint prior = table.to_grid(parameters_at(result.mapped_2d.maps, i));
    set_pixel(result.augmented.maps, i,
              table.from_grid(prior_fit.fit(&p.values[item * channels], &p.weights[item * channels], prior[0], prior[1])));
  }
}

// Each method's reconstruction under the photograph's illuminant and its ΔE94 against the photograph.
void compare_with_photograph(const session::MeasurementImage& photo, const session::MeasurementFile& m,
                             const ImportOptions& options, ImportResult& result) {
  const std::size_t pixels = static_cast<std::size_t>(m.width) * m.height;
  result.photograph_name = photo.name;
  result.photograph_rgb.resize(3 * pixels);
  for (int c = 0; c < 3; ++c) {
    const std::vector<float>& plane = photo.pixels.channel(std::string(1, "RGB"[c]));
    for (std::size_t i = 0; i < pixels; ++i) result.photograph_rgb[3 * i + c] = plane[i];
  }
  std::vector<Eigen::Vector3d> photograph(pixels);
  for (std::size_t i = 0; i < pixels; ++i)
    photograph[i] = {result.photograph_rgb[3 * i], result.photograph_rgb[3 * i + 1], result.photograph_rgb[3 * i + 2]};
  const spectral::CameraWeights camera_weights = spectral::camera_weights(m.camera, photo.illuminant);
  for (MethodResult* method : {&result.mapped_2d, &result.augmented, &result.search_4d}) {
    const RelitImage relit = relight(method->maps, camera_weights, options.threads);
    method->camera_rgb = relit.rgb;
    std::vector<Eigen::Vector3d> reconstruction(pixels);
    for (std::size_t i = 0; i < pixels; ++i)
      reconstruction[i] = result.compared[i] && relit.valid[i]
                              ? Eigen::Vector3d(relit.rgb[3 * i], relit.rgb[3 * i + 1], relit.rgb[3 * i + 2])
                              : Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
    method->delta_e94 = photo_delta_e94_map(photograph, reconstruction, m.camera, photo.illuminant);
    std::vector<double> finite;
    for (std::size_t i = 0; i < pixels; ++i)
      if (std::isfinite(method->delta_e94[i]) && (options.statistics_mask.empty() || options.statistics_mask[i]))
        finite.push_back(method->delta_e94[i]);
    method->stats = delta_e_stats(std::move(finite));
  }
}

}  // namespace

ImportResult import_external_maps(const ExternalMaps& external, const session::MeasurementFile& m, const ImportOptions& options) {
  const session::MeasurementImage& photo = checked_import(external, m, options);
  const estimation::MeasurementSet set = m.measurement_set();
  set.validate();
  const std::vector<float> measured = m.pixel_major();
  const std::size_t pixels = static_cast<std::size_t>(m.width) * m.height;
  const int channels = set.size();
  auto table = estimation::ForwardTable::load_or_build(set, {},
                                           options.cache_dir.empty() ? estimation::ForwardTable::default_cache_dir() : options.cache_dir,
                                           nullptr, options.threads);
  ImportResult result;

  // 4D search, and the 2D inversion the mapping is fitted to.
  auto t = std::chrono::steady_clock::now();
  estimation::EstimatorOptions eo;
  eo.method = options.search_4d, eo.model = estimation::ModelChoice::k4d, eo.threads = options.threads;
  std::vector<estimation::PixelEstimate> fit4(pixels), fit2(pixels);
  estimation::Estimator(table, set, eo).estimate(measured, fit4);
  result.seconds_4d = seconds_since(t);
  t = std::chrono::steady_clock::now();
  eo.method = estimation::InverterMethod::k2d, eo.model = estimation::ModelChoice::k2d;
  const estimation::Estimator estimator_2d(table, set, eo);
  estimator_2d.estimate(measured, fit2);
  const ComparedPixels compared = compared_pixels(external, set, measured, fit4, fit2, result.compared);
  fit_mappings(compared, *table, channels, options, result);
  fill_4d_and_mapped(external, fit4, m.width, m.height, result);
  result.seconds_2d = seconds_since(t);

  t = std::chrono::steady_clock::now();
  fit_augmented(compared, *table, channels, options, result);
  result.seconds_augmented = seconds_since(t);

  compare_with_photograph(photo, m, options, result);
  return result;
}

}  // namespace chromo::maps
