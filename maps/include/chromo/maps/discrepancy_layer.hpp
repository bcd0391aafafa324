#pragma once
// The relit layer "model + discrepancy" stored with the maps, so that every
// relighting (at estimate time and later from a stored maps.exr) adds each
// pixel's posterior discrepancy to the model's albedo (docs/estimation.md
// "Relighting past the model"; format: docs/formats/maps.md).
//
// Per explained pixel (flag 0) the posterior mean of the model's discrepancy
// spectrum given its channel residual r = values − W·model(fit) is
// (estimation/discrepancy_posterior.hpp, zero-mean prior with Σ_r)
//   d̂ = Σ_r Wᵀ (W Σ_r Wᵀ + N)⁻¹ r,
// N the pixel's noise (the channel's noise model at its value, divided by the
// pixels the multi-pixel estimate averaged into it, plus the table's model
// error). d̂ is kept as K coefficients c = Bᵀ d̂ on a basis B (81 × K,
// orthonormal columns: the K leading eigenvectors of Σ_r), so that the relit
// albedo is model(fit) + B c. Zero where the fit left no residual and on
// every pixel that is not explained (no coefficient changes its relighting).
// The residual uses the forward table's prediction at the fit (the one the
// estimator fitted), not the 81-wavelength model.
//
// Files: maps.exr channels discrepancy_0 … discrepancy_<K-1> (albedo units)
// and the header string attribute "chromo.discrepancy_basis" (the basis as
// CSV text, discrepancy_basis_text); maps without the channels relight with
// the model alone, as before.
//
// Thread rules: free functions over their arguments; immutable values.

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "chromo/estimation/estimator.hpp"
#include "chromo/estimation/forward_table.hpp"
#include "chromo/estimation/model_discrepancy.hpp"
#include "chromo/files/float_image.hpp"
#include "chromo/spectral/camera.hpp"

namespace chromo::maps {

inline constexpr int kDiscrepancyLayerTerms = 6;  // K by default (docs/estimation.md: K against the full posterior)
inline constexpr const char* kDiscrepancyBasisAttribute = "chromo.discrepancy_basis";
inline constexpr const char* kDiscrepancyChannelPrefix = "discrepancy_";

// B: 81 × K, orthonormal columns (albedo per unit coefficient).
struct DiscrepancyBasis {
  Eigen::MatrixXd spectra;
  int terms() const { return static_cast<int>(spectra.cols()); }
};

// The K (1-81) leading eigenvectors of the discrepancy's Σ_r, each signed so
// that its largest-magnitude sample is positive. std::invalid_argument for K
// out of range.
DiscrepancyBasis discrepancy_basis(const estimation::ModelDiscrepancy& discrepancy, int terms = kDiscrepancyLayerTerms);

// The attribute's text: a version line "# chromo discrepancy basis v1", then
// CSV "wavelength_nm,b0,…" with one row per grid wavelength; and its parser,
// which throws std::invalid_argument naming `source` and what is wrong
// (version, header, wavelengths, a value, columns not orthonormal).
std::string discrepancy_basis_text(const DiscrepancyBasis& basis);
DiscrepancyBasis parse_discrepancy_basis(std::string_view text, const std::string& source);

// The layer of a whole image: the basis and K planes of coefficients (width × height each).
struct DiscrepancyLayer {
  DiscrepancyBasis basis;
  std::vector<std::vector<float>> coefficients;
  std::size_t pixels = 0;  // pixels given a posterior discrepancy (explained, finite)
  double seconds = 0;      // computing it, wall
  // The coefficients of one pixel (K values) into `c`.
  void at(std::size_t pixel, double* c) const;
};

// What discrepancy_layer needs of the estimate chain.
struct DiscrepancyLayerInput {
  const estimation::ForwardTable* table = nullptr;  // the plan's table (the estimator's)
  const estimation::MeasurementSet* set = nullptr;  // its channels and their noise models
  std::span<const float> values;                    // pixels × channels: what the estimates were fitted to
  std::span<const std::uint16_t> averaged;          // per pixel the pixels averaged into `values` (empty: 1)
  std::span<const estimation::PixelEstimate> estimates;
  double model_sigma_relative = 0;                  // the estimator's table error (EstimatorOptions)
};

// The layer above. Throws std::invalid_argument naming the input that is
// missing or of the wrong size.
DiscrepancyLayer discrepancy_layer(const DiscrepancyLayerInput& input, const estimation::ModelDiscrepancy& discrepancy,
                                   int terms = kDiscrepancyLayerTerms, int threads = 0);

// maps.exr's channels and attribute for the layer (appended to `image`), and
// the layer read back from an image (std::nullopt: no discrepancy channels;
// std::invalid_argument naming `source` when the channels and the basis
// disagree or the basis is missing or malformed).
void add_discrepancy_layer(files::FloatImage& image, const DiscrepancyLayer& layer);
std::optional<DiscrepancyLayer> read_discrepancy_layer(const files::FloatImage& image, const std::string& source);

// The layer seen through 3 × 81 weights (camera_weights, linear_srgb_weights,
// XYZ): 3 × K, so that a pixel's relit value gains (weights · B) c.
Eigen::Matrix<double, 3, Eigen::Dynamic> projected_basis(const DiscrepancyBasis& basis,
                                                         const spectral::CameraWeights& weights);

}  // namespace chromo::maps
