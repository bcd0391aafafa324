#include "chromo/maps/discrepancy_layer.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include <omp.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "chromo/spectral/grid.hpp"
#include "chromo/spectral/table.hpp"

namespace chromo::maps {

namespace {
constexpr const char* kBasisVersionLine = "# chromo discrepancy basis v1";
constexpr double kOrthonormalTolerance = 1e-4;  // the text keeps 9 significant digits
}  // namespace

DiscrepancyBasis discrepancy_basis(const estimation::ModelDiscrepancy& discrepancy, int terms) {
  if (terms < 1 || terms > spectral::kGridSize)
    throw std::invalid_argument("discrepancy basis: terms " + std::to_string(terms) + " (1-81)");
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(discrepancy.covariance());
  // Eigen sorts ascending: the leading vectors are the last columns.
  DiscrepancyBasis basis;
  basis.spectra = eigen.eigenvectors().rightCols(terms).rowwise().reverse();
  for (int k = 0; k < terms; ++k) {
    Eigen::Index largest = 0;
    basis.spectra.col(k).cwiseAbs().maxCoeff(&largest);
    if (basis.spectra(largest, k) < 0) basis.spectra.col(k) *= -1;
  }
  return basis;
}

std::string discrepancy_basis_text(const DiscrepancyBasis& basis) {
  std::string text = std::string(kBasisVersionLine) +
                     ": the relit albedo is the model's plus sum_k c_k b_k(lambda), c_k the maps' channel "
                     "discrepancy_<k> (docs/formats/maps.md)\nwavelength_nm";
  for (int k = 0; k < basis.terms(); ++k) text += ",b" + std::to_string(k);
  text += "\n";
  char number[32];
  for (int i = 0; i < spectral::kGridSize; ++i) {
    std::snprintf(number, sizeof number, "%g", spectral::grid_wavelength_nm(i));
    text += number;
    for (int k = 0; k < basis.terms(); ++k) {
      std::snprintf(number, sizeof number, ",%.9g", basis.spectra(i, k));
      text += number;
    }
    text += "\n";
  }
  return text;
}

DiscrepancyBasis parse_discrepancy_basis(std::string_view text, const std::string& source) {
  auto fail = [&](const std::string& what) { return std::invalid_argument(source + ": discrepancy basis: " + what); };
  if (text.substr(0, std::string_view(kBasisVersionLine).size()) != kBasisVersionLine)
    throw fail("does not start with \"" + std::string(kBasisVersionLine) + "\" (an unknown version)");
  spectral::Table table;
  try {
    table = spectral::parse_table(text, source);
  } catch (const spectral::DataError& e) {
    throw fail(e.what());
  }
  const int terms = static_cast<int>(table.column_names.size()) - 1;
  if (terms < 1 || table.column_names.front() != "wavelength_nm") throw fail("expected columns wavelength_nm,b0,...");
  if (table.rows() != static_cast<std::size_t>(spectral::kGridSize))
    throw fail(std::to_string(table.rows()) + " rows, not the grid's " + std::to_string(spectral::kGridSize));
  DiscrepancyBasis basis;
  basis.spectra.resize(spectral::kGridSize, terms);
  for (int i = 0; i < spectral::kGridSize; ++i) {
    if (std::abs(table.columns[0][i] - spectral::grid_wavelength_nm(i)) > 1e-6)
      throw fail("row " + std::to_string(i + 1) + " is at " + std::to_string(table.columns[0][i]) + " nm, not " +
                 std::to_string(spectral::grid_wavelength_nm(i)));
    for (int k = 0; k < terms; ++k) basis.spectra(i, k) = table.columns[k + 1][i];
  }
  if (!basis.spectra.allFinite()) throw fail("a value is not finite");
  const Eigen::MatrixXd gram = basis.spectra.transpose() * basis.spectra;
  if (!gram.isIdentity(kOrthonormalTolerance)) throw fail("the columns are not orthonormal");
  return basis;
}

void DiscrepancyLayer::at(std::size_t pixel, double* c) const {
  for (std::size_t k = 0; k < coefficients.size(); ++k) c[k] = coefficients[k][pixel];
}

DiscrepancyLayer discrepancy_layer(const DiscrepancyLayerInput& input, const estimation::ModelDiscrepancy& discrepancy,
                                   int terms, int threads) {
  const auto start = std::chrono::steady_clock::now();
  if (!input.table || !input.set) throw std::invalid_argument("discrepancy layer: no table or measurement set");
  const int channels = input.set->size();
  const std::size_t pixels = input.estimates.size();
  if (input.table->channels() != channels)
    throw std::invalid_argument("discrepancy layer: the table has " + std::to_string(input.table->channels()) +
                                " channels, the set " + std::to_string(channels));
  if (input.values.size() != pixels * static_cast<std::size_t>(channels))
    throw std::invalid_argument("discrepancy layer: " + std::to_string(input.values.size()) + " values for " +
                                std::to_string(pixels) + " pixels of " + std::to_string(channels) + " channels");
  if (!input.averaged.empty() && input.averaged.size() != pixels)
    throw std::invalid_argument("discrepancy layer: " + std::to_string(input.averaged.size()) + " averaged counts for " +
                                std::to_string(pixels) + " pixels");
  DiscrepancyLayer layer;
  layer.basis = discrepancy_basis(discrepancy, terms);
  layer.coefficients.assign(static_cast<std::size_t>(terms), std::vector<float>(pixels, 0.0f));
  const Eigen::MatrixXd w = input.set->weights();
  const Eigen::MatrixXd gain = discrepancy.covariance() * w.transpose();  // Σ_r Wᵀ, 81 × C
  const Eigen::MatrixXd seen = w * gain;                                  // W Σ_r Wᵀ
  const Eigen::MatrixXd projected_gain = layer.basis.spectra.transpose() * gain;  // Bᵀ Σ_r Wᵀ, K × C
  std::size_t given = 0;
  const auto count = static_cast<std::ptrdiff_t>(pixels);
#pragma omp parallel for schedule(dynamic, 4096) num_threads(threads > 0 ? threads : omp_get_max_threads()) reduction(+ : given)
  for (std::ptrdiff_t p = 0; p < count; ++p) {
    const auto i = static_cast<std::size_t>(p);
    const estimation::PixelEstimate& e = input.estimates[i];
    if (e.flag != estimation::PixelFlag::kExplained || !std::isfinite(e.parameters.cm) || !std::isfinite(e.parameters.ch) ||
        !std::isfinite(e.parameters.bm) || !std::isfinite(e.parameters.che))
      continue;
    Eigen::VectorXd predicted(channels), residual(channels);
    input.table->predict(input.table->to_grid(e.parameters), predicted.data());
    Eigen::MatrixXd total = seen;
    const double averaged = input.averaged.empty() ? 1.0 : std::max<double>(input.averaged[i], 1.0);
    bool finite = true;
    for (int c = 0; c < channels; ++c) {
      const double value = input.values[i * static_cast<std::size_t>(channels) + static_cast<std::size_t>(c)];
      const double model = input.model_sigma_relative * std::max(value, 0.0);
      residual(c) = value - predicted(c);
      total(c, c) += input.set->channels[static_cast<std::size_t>(c)].noise.variance(value) / averaged + model * model;
      finite = finite && std::isfinite(value);
    }
    if (!finite) continue;
    const Eigen::VectorXd c = projected_gain * total.ldlt().solve(residual);
    for (int k = 0; k < terms; ++k) layer.coefficients[static_cast<std::size_t>(k)][i] = static_cast<float>(c(k));
    ++given;
  }
  layer.pixels = given;
  layer.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return layer;
}

void add_discrepancy_layer(files::FloatImage& image, const DiscrepancyLayer& layer) {
  for (int k = 0; k < layer.basis.terms(); ++k) {
    image.channel_names.push_back(kDiscrepancyChannelPrefix + std::to_string(k));
    image.channels.push_back(layer.coefficients[static_cast<std::size_t>(k)]);
  }
  image.attributes.emplace_back(kDiscrepancyBasisAttribute, discrepancy_basis_text(layer.basis));
}

std::optional<DiscrepancyLayer> read_discrepancy_layer(const files::FloatImage& image, const std::string& source) {
  int channels = 0;
  while (std::find(image.channel_names.begin(), image.channel_names.end(),
                   kDiscrepancyChannelPrefix + std::to_string(channels)) != image.channel_names.end())
    ++channels;
  const std::string* text = image.attribute(kDiscrepancyBasisAttribute);
  if (channels == 0 && !text) return std::nullopt;
  if (!text)
    throw std::invalid_argument(source + ": channels discrepancy_0.." + std::to_string(channels - 1) +
                                " without the header attribute " + kDiscrepancyBasisAttribute);
  DiscrepancyLayer layer;
  layer.basis = parse_discrepancy_basis(*text, source);
  if (layer.basis.terms() != channels)
    throw std::invalid_argument(source + ": " + std::to_string(channels) + " discrepancy_<k> channels but a basis of " +
                                std::to_string(layer.basis.terms()) + " terms");
  for (int k = 0; k < channels; ++k) layer.coefficients.push_back(image.channel(kDiscrepancyChannelPrefix + std::to_string(k)));
  const std::size_t pixels = static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height);
  for (std::size_t i = 0; i < pixels; ++i) {
    bool nonzero = false;
    for (const auto& plane : layer.coefficients) nonzero = nonzero || plane[i] != 0.0f;
    layer.pixels += nonzero;
  }
  return layer;
}

Eigen::Matrix<double, 3, Eigen::Dynamic> projected_basis(const DiscrepancyBasis& basis,
                                                         const spectral::CameraWeights& weights) {
  return weights * basis.spectra;
}

}  // namespace chromo::maps
