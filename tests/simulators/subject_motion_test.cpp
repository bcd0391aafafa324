// Subject motion in the virtual lab (simulators/scene/subject_motion.hpp) and
// what it costs the rendered session's registration: a longer plan leaves
// the subject more time to drift, and the magnification change of its axial
// drift is what a Euclidean registration cannot undo.
#include <gtest/gtest.h>

#include <cmath>

#include "chromo/simulators/scene/rendered_session.hpp"
#include "chromo/simulators/scene/subject_motion.hpp"

namespace chromo::simulators {
namespace {

TEST(SubjectMotion, PoseIsDriftPlusTremor) {
  SubjectMotionOptions o;
  EXPECT_EQ(subject_pose(o, 2.0, 1).dx_px, 0);  // off by default
  o.enabled = true;
  o.tremor_sigma_mm = 0, o.tremor_sigma_deg = 0;
  const SubjectPose p = subject_pose(o, 2.0, 1);
  EXPECT_NEAR(p.dx_px, 0.10 * 2 / 0.025, 1e-12);
  EXPECT_NEAR(p.dy_px, 0.05 * 2 / 0.025, 1e-12);
  EXPECT_NEAR(p.rotation_deg, 0.1, 1e-12);
  EXPECT_NEAR(p.scale, 1 / (1 - 0.4 / 250), 1e-12);
  // Tremor: per capture, seeded; the reference capture (index 0) has none.
  SubjectMotionOptions t;
  t.enabled = true;
  t.drift_x_mm_per_s = t.drift_y_mm_per_s = t.drift_deg_per_s = t.axial_drift_mm_per_s = 0;
  EXPECT_EQ(subject_pose(t, 0, 0).dx_px, 0);
  double sum = 0;
  for (int k = 1; k <= 2000; ++k) sum += std::pow(subject_pose(t, 0, k).dx_px, 2);
  EXPECT_NEAR(std::sqrt(sum / 2000), 0.02 / 0.025, 0.05);
  EXPECT_EQ(subject_pose(t, 0, 3).dx_px, subject_pose(t, 0, 3).dx_px);
  // The map: the centre moves by the shift only.
  const cv::Matx23d m = pose_matrix(p, 100, 50);
  EXPECT_NEAR(m(0, 0) * 100 + m(0, 1) * 50 + m(0, 2), 100 + p.dx_px, 1e-9);
  EXPECT_NEAR(m(1, 0) * 100 + m(1, 1) * 50 + m(1, 2), 50 + p.dy_px, 1e-9);
}

TEST(SubjectMotion, BadOptionsAreRefusedNamingTheField) {
  RenderedSessionOptions o;
  o.motion.working_distance_mm = 0;
  std::string error;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_EQ(error, "motion.working_distance_mm: must be 20-5000");
  o.motion = {};
  o.motion.tremor_sigma_mm = -1;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_EQ(error, "motion.tremor_sigma_mm: must be 0-5");
  o.motion = {};
  o.readout_ms = -1;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_EQ(error, "readout_ms: must be 0-10000");
  EXPECT_THROW(render_session(o), std::invalid_argument);
}

RenderedSessionOptions lab(bool motion, std::uint32_t settle_ms) {
  RenderedSessionOptions o;
  o.sensor_width = 256, o.sensor_height = 192;
  o.scene_width = 2592, o.scene_height = 1944;
  o.window_x = 640, o.window_y = 1680;  // skin with a hair strand and a mole: texture for the registration
  o.seed = 5;
  o.noise_free = false;
  o.motion.enabled = motion;
  o.settle_ms = settle_ms;
  return o;
}

TEST(SubjectMotion, RegistrationErrorIsReportedAndGrowsWithPlanDuration) {
  const RenderedSession still = render_session(lab(false, 50));
  ASSERT_EQ(still.motion.size(), 2u);
  for (const CaptureMotion& c : still.motion) {
    EXPECT_EQ(c.pose.scale, 1.0);
    EXPECT_LT(c.registration_error_max_px, 0.15) << c.capture;  // registration noise only
  }
  const RenderedSession quick = render_session(lab(true, 50));
  const RenderedSession slow = render_session(lab(true, 2000));
  ASSERT_EQ(quick.motion.size(), 2u);
  ASSERT_EQ(slow.motion.size(), 2u);
  EXPECT_GT(slow.plan_seconds, 5 * quick.plan_seconds);
  for (int k = 0; k < 2; ++k) {
    const CaptureMotion& q = quick.motion[k];
    const CaptureMotion& s = slow.motion[k];
    EXPECT_GT(s.seconds_since_reference, q.seconds_since_reference);
    // The registration followed the drift (it found motion of the drift's size)...
    EXPECT_GT(s.found_motion_px, 2.0) << s.capture;
    // ...but not the magnification: the error grows with the time since the reference.
    EXPECT_GT(s.registration_error_max_px, q.registration_error_max_px) << s.capture;
    EXPECT_GT(s.registration_error_max_px, 0.1) << s.capture;
  }
  EXPECT_GT(slow.motion[1].registration_error_max_px, slow.motion[0].registration_error_max_px);
}

}  // namespace
}  // namespace chromo::simulators
