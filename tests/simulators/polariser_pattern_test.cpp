// The light-side polariser pattern (docs/polarisation.md, "Geometry"): the
// design view is crossed exactly; other views leak, more the farther they are.

#include <gtest/gtest.h>

#include <cstdio>

#include "chromo/simulators/polarisation/polariser_pattern.hpp"
#include "chromo/simulators/scene/camera_view.hpp"

namespace chromo::simulators {
namespace {

cv::Vec3d view_at(double azimuth_deg, double elevation_deg = 0) {
  return orbit_eye_mm(300, azimuth_deg, elevation_deg);
}

TEST(PolariserPattern, TheDesignViewIsCrossedExactlyForEveryLight) {
  for (double roughness : {0.05, 0.3, 1.0}) {
    const CrossPolarisationLeak leak = cross_polarisation_leak(view_at(0), view_at(0), roughness);
    EXPECT_LT(leak.lobe_leak, 1e-20) << roughness;
    EXPECT_LT(leak.mirror_leak, 1e-20);
    EXPECT_EQ(leak.analyser_angle_deg, 0.0);
  }
  // A design camera elsewhere is crossed exactly too.
  EXPECT_LT(cross_polarisation_leak(view_at(20, 10), view_at(20, 10), 0.3).lobe_leak, 1e-20);
}

TEST(PolariserPattern, OtherViewsLeakMoreTheFartherTheyAre) {
  double previous = 0;
  for (double azimuth : {10.0, 20.0, 30.0, 45.0}) {
    const CrossPolarisationLeak smooth = cross_polarisation_leak(view_at(0), view_at(azimuth), 0.1);
    const CrossPolarisationLeak rough = cross_polarisation_leak(view_at(0), view_at(azimuth), 0.3);
    std::printf("azimuth %4.0f deg: analyser %6.2f deg, mirror leak %.4f, lobe leak %.4f (0.1 rad) %.4f (0.3 rad)\n",
                azimuth, rough.analyser_angle_deg, rough.mirror_leak, smooth.lobe_leak, rough.lobe_leak);
    EXPECT_GT(rough.lobe_leak, previous) << azimuth;
    EXPECT_LT(rough.lobe_leak, 0.5) << azimuth;  // still far better than no polariser (0.5 of the light)
    previous = rough.lobe_leak;
    // Left and right are mirror images.
    EXPECT_NEAR(cross_polarisation_leak(view_at(0), view_at(-azimuth), 0.3).lobe_leak, rough.lobe_leak,
                1e-3 * rough.lobe_leak);  // up to the light set, which is not mirror-symmetric
  }
}

TEST(PolariserPattern, AboveTheDesignPlaneTheAnalyserTurnsAndTheLobeLeaksMore) {
  // The mirror light alone can always be crossed by turning the analyser; the
  // lobe's other lights cannot, and leak more out of the design plane.
  double previous = cross_polarisation_leak(view_at(0), view_at(20), 0.3).lobe_leak;
  for (double elevation : {10.0, 20.0}) {
    const CrossPolarisationLeak leak = cross_polarisation_leak(view_at(0), view_at(20, elevation), 0.3);
    std::printf("azimuth 20 deg, elevation %2.0f deg: analyser %6.2f deg, mirror leak %.2e, lobe leak %.4f (0.3 rad)\n",
                elevation, leak.analyser_angle_deg, leak.mirror_leak, leak.lobe_leak);
    EXPECT_GT(leak.analyser_angle_deg, 0.5) << elevation;
    EXPECT_LT(leak.mirror_leak, 1e-3) << elevation;
    EXPECT_GT(leak.lobe_leak, previous) << elevation;
    previous = leak.lobe_leak;
  }
}

TEST(PolariserPattern, RefusesViewsBehindThePatchAndBadParameters) {
  EXPECT_THROW(cross_polarisation_leak({0, 0, 1}, view_at(0), 0.3), std::invalid_argument);
  EXPECT_THROW(cross_polarisation_leak(view_at(0), view_at(0), 0.0), std::invalid_argument);
  EXPECT_THROW(cross_polarisation_leak(view_at(0), view_at(0), 0.3, 0, 10), std::invalid_argument);
}

}  // namespace
}  // namespace chromo::simulators
