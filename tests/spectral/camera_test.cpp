#include "chromo/spectral/camera.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>

#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/table.hpp"

using namespace chromo::spectral;

namespace {

TEST(Camera, WhiteGivesOneAndResponseIsLinear) {
  const CameraSensitivity nikon = builtin_camera("nikon_d5100");
  for (const Spectrum* illuminant : {&illuminant_d65(), &illuminant_a()}) {
    const Eigen::Vector3d white = camera_response(nikon, *illuminant, Spectrum::constant(1.0));
    EXPECT_NEAR(white.x(), 1.0, 1e-12);
    EXPECT_NEAR(white.y(), 1.0, 1e-12);
    EXPECT_NEAR(white.z(), 1.0, 1e-12);
    const Eigen::Vector3d grey = camera_response(nikon, *illuminant, Spectrum::constant(0.25));
    EXPECT_NEAR(grey.z(), 0.25, 1e-12);
  }
}

TEST(Camera, ResponseIsTheSensitivityIlluminantWeightedMean) {
  // Albedo that is 1 in one grid bin only: the response is that bin's share
  // of Σ S·E, computed here by hand from the tables.
  const CameraSensitivity nikon = builtin_camera("nikon_d5100");
  const Spectrum& d65 = illuminant_d65();
  Spectrum spike;
  spike[34] = 1.0;  // 550 nm
  const Eigen::Vector3d r = camera_response(nikon, d65, spike);
  double total = 0;
  for (int i = 0; i < kGridSize; ++i) total += nikon.rgb[1][i] * d65[i];
  EXPECT_NEAR(r.y(), nikon.rgb[1][34] * d65[34] / total, 1e-15);
  EXPECT_GT(r.y(), r.z());  // green channel sees 550 nm more than blue
}

TEST(Camera, UnknownCameraAndBadFileAreErrors) {
  EXPECT_THROW(builtin_camera("hasselblad"), DataError);
  const std::string path = ::testing::TempDir() + "/cam_missing_b.csv";
  std::ofstream(path) << "wavelength_nm,R,G\n380,1,1\n780,1,1\n";
  EXPECT_THROW(read_camera_sensitivity(path), DataError);
  std::remove(path.c_str());
}

TEST(Camera, ChannelBlindToIlluminantIsAnError) {
  CameraSensitivity cam = builtin_camera("nikon_d5100");
  Spectrum red_only;
  for (int i = 60; i < kGridSize; ++i) red_only[i] = 1.0;  // 680-780 nm
  cam.rgb[2] = Spectrum();                                  // blue channel zero everywhere
  EXPECT_THROW(camera_weights(cam, red_only), DataError);
}

}  // namespace
