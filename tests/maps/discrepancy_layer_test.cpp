// The relit layer "model + discrepancy" in the maps (maps/discrepancy_layer.hpp):
// its coefficients, its basis in the file, and every relighting adding it.
#include "chromo/maps/discrepancy_layer.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "chromo/estimation/discrepancy_posterior.hpp"
#include "chromo/estimation/skin_model.hpp"
#include "chromo/maps/map_operations.hpp"
#include "chromo/maps/relight.hpp"
#include "chromo/simulators/scene/synthetic.hpp"
#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/delta_e.hpp"
#include "chromo/spectral/lab_illuminants.hpp"
#include "maps_fixture.hpp"

namespace chromo::maps {
namespace {

using ::testing::HasSubstr;

// The six LED types one at a time (18 channels) with a faint camera noise, and its table on a coarse grid.
struct SixLeds {
  estimation::MeasurementSet set;
  estimation::ForwardTable table;
  SixLeds() {
    std::vector<std::pair<std::string, spectral::Spectrum>> leds;
    for (auto type : spectral::kAllLedTypes)
      leds.emplace_back(std::string(spectral::led_type_name(type)), spectral::led_spectrum(type));
    set = simulators::capture_measurement_set(spectral::builtin_camera("nikon_d5100"), leds);
    for (auto& c : set.channels) c.noise.read_sigma = 1e-3, c.noise.shot_coefficient = 1e-6, c.noise.white_coefficient = 0;
    table = estimation::ForwardTable::build(set, estimation::TableGrid{5, 5, 11, 5}, 2);
  }
};

spectral::Lab lab_d65(const spectral::Spectrum& albedo) {
  return spectral::lab_from_xyz(spectral::xyz_of_reflectance(albedo, spectral::illuminant_d65()),
                                spectral::white_point(spectral::illuminant_d65()));
}

// A pixel whose channels are the model's plus a real skin's discrepancy gets
// Bᵀ of the posterior mean (discrepancy_posterior.hpp) and relights closer to
// that skin; one the model explains exactly gets nothing, nor does a flagged
// one; the averaged count divides the noise.
TEST(DiscrepancyLayer, CoefficientsAreTheProjectedPosteriorAndNothingWithoutAResidual) {
  const SixLeds lab;
  const auto discrepancy = estimation::ModelDiscrepancy::standard();
  const estimation::SkinParameters p{0.05, 0.02, 0.7, 0.01};
  const int channels = lab.set.size();
  std::vector<double> predicted(static_cast<std::size_t>(channels));
  lab.table.predict(lab.table.to_grid(p), predicted.data());
  const spectral::Spectrum d = estimation::nist_forearm_residuals()[7].residual;
  const Eigen::VectorXd seen = lab.set.weights() * d.values().matrix();
  std::vector<float> values;
  for (int pixel = 0; pixel < 4; ++pixel)
    for (int c = 0; c < channels; ++c) values.push_back(static_cast<float>(predicted[c] + (pixel == 0 ? 0.0 : seen(c))));
  std::vector<estimation::PixelEstimate> estimates(4);
  for (auto& e : estimates) e.parameters = p;
  estimates[2].flag = estimation::PixelFlag::kUnexplainedColour;
  const std::vector<std::uint16_t> averaged{1, 1, 1, 4};
  DiscrepancyLayerInput input{&lab.table, &lab.set, values, averaged, estimates, 0.003};
  const DiscrepancyLayer layer = discrepancy_layer(input, *discrepancy, 6, 1);
  ASSERT_EQ(layer.basis.terms(), 6);
  EXPECT_EQ(layer.pixels, 3u);
  const estimation::DiscrepancyPosterior posterior(*discrepancy, lab.set);
  for (int pixel : {1, 3}) {
    std::vector<double> residual(channels), variance(channels);
    for (int c = 0; c < channels; ++c) {
      const double v = values[pixel * channels + c];
      residual[c] = v - predicted[c];
      variance[c] = lab.set.channels[c].noise.variance(v) / averaged[pixel] + std::pow(0.003 * v, 2);
    }
    const Eigen::VectorXd expected =
        layer.basis.spectra.transpose() * posterior.mean(residual, variance).values().matrix();
    for (int k = 0; k < 6; ++k) EXPECT_NEAR(layer.coefficients[k][pixel], expected(k), 1e-6) << pixel << " " << k;
  }
  EXPECT_NE(layer.coefficients[0][1], layer.coefficients[0][3]);  // less noise, a different posterior
  for (int k = 0; k < 6; ++k) {
    EXPECT_NEAR(layer.coefficients[k][0], 0.0, 1e-6);
    EXPECT_EQ(layer.coefficients[k][2], 0.0f);
  }
  // Relit under D65, the skin the pixel saw (model + d) is nearer with the layer.
  static const estimation::SkinModel model;
  const spectral::Spectrum fitted = model.albedo(p), truth = fitted + d;
  double c[6];
  layer.at(1, c);
  const Eigen::VectorXd added = layer.basis.spectra * Eigen::Map<const Eigen::VectorXd>(c, 6);
  const spectral::Spectrum relit = fitted + spectral::Spectrum(spectral::GridArray(added.array()));
  EXPECT_LT(spectral::delta_e94(lab_d65(truth), lab_d65(relit)), 0.6 * spectral::delta_e94(lab_d65(truth), lab_d65(fitted)));

  input.values = std::span<const float>(values).first(10);
  EXPECT_THAT([&] { discrepancy_layer(input, *discrepancy); },
              ::testing::ThrowsMessage<std::invalid_argument>(HasSubstr("values")));
}

TEST(DiscrepancyLayer, BasisTextRoundTripsAndABadOneIsRefusedByName) {
  const DiscrepancyBasis basis = discrepancy_basis(*estimation::ModelDiscrepancy::standard(), 4);
  EXPECT_TRUE((basis.spectra.transpose() * basis.spectra).isIdentity(1e-9));
  const std::string text = discrepancy_basis_text(basis);
  EXPECT_TRUE(parse_discrepancy_basis(text, "f").spectra.isApprox(basis.spectra, 1e-7));
  auto refused = [](const std::string& bad) {
    try {
      parse_discrepancy_basis(bad, "maps.exr");
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_THAT(refused("# chromo discrepancy basis v9\n" + text), HasSubstr("unknown version"));
  std::string doubled = text;
  doubled.replace(doubled.find("\n380,") + 5, 1, "9");  // b0 at 380 nm no longer of unit norm with the rest
  EXPECT_THAT(refused(doubled), HasSubstr("orthonormal"));
  EXPECT_THAT(refused(text.substr(0, text.size() / 2)), HasSubstr("maps.exr"));
  EXPECT_THROW(discrepancy_basis(*estimation::ModelDiscrepancy::standard(), 0), std::invalid_argument);
}

// Stored maps with the layer relight with it (relight(), relight_to_files, a
// flush keeps it); off relights the model alone; maps without it relight as
// before; channels without their basis are refused naming the attribute.
TEST(DiscrepancyLayer, EveryRelightingOfStoredMapsAddsItAndOldMapsRelightAsBefore) {
  const std::filesystem::path dir = testing::fresh_directory("discrepancy-layer");
  const ParameterMaps plain = testing::uniform_maps(3, 2, 0.05f, 0.02f, 0.7f, 0.01f);
  DiscrepancyLayer layer;
  layer.basis = discrepancy_basis(*estimation::ModelDiscrepancy::standard(), 3);
  layer.coefficients.assign(3, std::vector<float>(6, 0.0f));
  layer.coefficients[0][0] = 0.08f, layer.coefficients[2][0] = -0.04f;
  files::FloatImage image{3, 2, {"Cm", "Ch", "Bm", "Che", "flags"}, {plain.cm, plain.ch, plain.bm, plain.che, plain.flags}};
  add_discrepancy_layer(image, layer);
  files::write_exr(dir / "maps.exr", image);
  testing::write_maps(dir / "old.exr", plain);

  const ParameterMaps stored = read_parameter_maps(dir / "maps.exr");
  ASSERT_TRUE(stored.discrepancy.has_value());
  EXPECT_EQ(stored.discrepancy->pixels, 1u);
  EXPECT_FALSE(read_parameter_maps(dir / "old.exr").discrepancy.has_value());
  const spectral::CameraWeights srgb = linear_srgb_weights(spectral::illuminant_a());
  const RelitImage with = relight(stored, srgb, 1), without = relight(plain, srgb, 1);
  const Eigen::Vector3d added = srgb * layer.basis.spectra * Eigen::Vector3d(0.08, 0.0, -0.04);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(with.rgb[c], without.rgb[c] + added(c), 1e-5);
    EXPECT_FLOAT_EQ(with.rgb[3 + c], without.rgb[3 + c]);  // a zero coefficient adds nothing
  }
  EXPECT_GT(added.norm(), 1e-3);

  RelightOptions o;
  o.maps = dir / "maps.exr", o.illuminant = "A", o.threads = 1;
  for (const bool on : {true, false}) {
    o.discrepancy_layer = on;
    o.out = dir / (on ? "on" : "off");
    const RelightSummary s = relight_to_files(o);
    EXPECT_EQ(s.discrepancy_layer, on);
    EXPECT_NEAR(files::read_exr(o.out / "relit.exr").channel("R")[0], (on ? with : without).rgb[0], 1e-6);
    EXPECT_THAT(nlohmann::json::parse(s.json)["discrepancy_layer"].get<std::string>(),
                HasSubstr(on ? "model + discrepancy" : "turned off"));
  }
  FlushOptions flush;
  flush.maps = dir / "maps.exr", flush.scale.ch = 1.5, flush.ellipse = EllipseShape{1, 1, 2, 2, 0}, flush.out = dir / "flush";
  flush.threads = 1;
  flush_to_files(flush);
  EXPECT_TRUE(read_parameter_maps(dir / "flush" / "maps.exr").discrepancy.has_value());

  image.attributes.clear();
  files::write_exr(dir / "no_basis.exr", image);
  EXPECT_THAT([&] { read_parameter_maps(dir / "no_basis.exr"); },
              ::testing::ThrowsMessage<std::runtime_error>(HasSubstr("chromo.discrepancy_basis")));
}

}  // namespace
}  // namespace chromo::maps
