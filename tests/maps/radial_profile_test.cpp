#include "chromo/maps/radial_profile.hpp"
#include "chromo/maps/profile_table.hpp"

#include <gtest/gtest.h>

#include "chromo/spectral/cie.hpp"

using namespace chromo::maps;

namespace {

// Building the Hankel kernel (2.4 million Bessel evaluations) is the slow
// part: the tests share one model.
const RadialProfileModel& d65_profiles() {
  static const chromo::estimation::SkinModel model;
  static const RadialProfileModel profiles(model, chromo::spectral::illuminant_d65());
  return profiles;
}

TEST(RadialProfile, PlaneIntegralGivesTheForwardModelAlbedo) {
  const RadialProfileModel& profiles = d65_profiles();
  for (const chromo::estimation::SkinParameters p : {chromo::estimation::SkinParameters{0.02, 0.02, 0.7, 0.0}, chromo::estimation::SkinParameters{0.3, 0.1, 0.4, 0.05},
                                 chromo::estimation::SkinParameters{0.001, 0.32, 1.0, 0.1}, chromo::estimation::SkinParameters{0.5, 0.001, 0.0, 0.0}}) {
    const RadialProfile profile = profiles.profile(p);
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(profile.plane_integral_rgb[c] / profile.albedo_rgb[c], 1.0, 0.005)
          << "channel " << c << " Cm " << p.cm << " Ch " << p.ch;
    }
  }
}

TEST(RadialProfile, RedFallsWithRadiusAndOutOfGamutTailsAreSmall) {
  const RadialProfileModel& profiles = d65_profiles();
  const RadialProfile profile = profiles.profile({0.05, 0.03, 0.7, 0.01});
  const auto n = static_cast<Eigen::Index>(profile.radius_mm.size());
  for (Eigen::Index i = 1; i < n && profile.radius_mm[i] < 8.0; ++i) {
    EXPECT_GT(profile.rgb_per_mm2(i, 0), 0.0) << "r " << profile.radius_mm[i];
    EXPECT_LT(profile.rgb_per_mm2(i, 0), profile.rgb_per_mm2(i - 1, 0)) << "r " << profile.radius_mm[i];
  }
  // Light that travelled millimetres is deep red, outside the sRGB gamut: G
  // and B may dip below zero there, but only by a little.
  for (int c = 0; c < 3; ++c) {
    const double peak = profile.rgb_per_mm2.col(c).maxCoeff();
    EXPECT_GT(profile.rgb_per_mm2.col(c).minCoeff(), -1e-3 * peak) << "channel " << c;
  }
  // Red spreads further than blue: at 1 mm red dominates.
  Eigen::Index at_1mm = 0;
  while (profile.radius_mm[at_1mm] < 1.0) ++at_1mm;
  EXPECT_GT(profile.rgb_per_mm2(at_1mm, 0), 10 * std::abs(profile.rgb_per_mm2(at_1mm, 2)));
}

TEST(RadialProfile, OptionsAreValidated) {
  std::string error;
  RadialProfileOptions options;
  EXPECT_TRUE(options.IsValid(&error)) << error;
  options.max_radius_mm = 100;  // 0.01 × 100 = 1 > 0.2
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_NE(error.find("≤ 0.2"), std::string::npos) << error;
  const chromo::estimation::SkinModel model;
  EXPECT_THROW(RadialProfileModel(model, chromo::spectral::illuminant_d65(), options), std::invalid_argument);
}

}  // namespace

// build_profile_table's Progress (files/progress.hpp): with one thread every
// entry is reported, in order, then 1; cancelled() stops it after the entry
// under way with files::Cancelled.
TEST(ProfileTable, ReportsEachEntryAndStopsWhenCancelled) {
  ProfileTableAxes axes = ProfileTableAxes::Default();
  axes.cm.resize(2);
  axes.ch.resize(2);
  ASSERT_EQ(axes.entry_count(), 36u);  // 2 × 2 × 3 βm × 3 Che

  std::vector<double> fractions;
  chromo::files::Progress progress;
  progress.on_progress = [&](double fraction, const std::string& step) {
    EXPECT_EQ(step, "profile table");
    fractions.push_back(fraction);
  };
  const ProfileTable table = build_profile_table(d65_profiles(), axes, "d65", 1, progress);
  EXPECT_EQ(table.albedo_rgb.size(), 36u * 3);
  ASSERT_EQ(fractions.size(), 37u);  // each entry, then 1 at the end
  for (std::size_t i = 0; i < 36; ++i) EXPECT_DOUBLE_EQ(fractions[i], (i + 1) / 36.0);
  EXPECT_DOUBLE_EQ(fractions.back(), 1.0);

  fractions.clear();
  progress.should_cancel = [&] { return fractions.size() >= 5; };
  try {
    build_profile_table(d65_profiles(), axes, "d65", 1, progress);
    ADD_FAILURE() << "a cancelled build returned a table";
  } catch (const chromo::files::Cancelled& cancelled) {
    EXPECT_STREQ(cancelled.what(), "cancelled");
  }
  ASSERT_EQ(fractions.size(), 5u);  // stopped after the fifth entry, no final 1
  EXPECT_DOUBLE_EQ(fractions.back(), 5 / 36.0);
}
