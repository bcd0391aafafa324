// Plans beyond the method's (issue 20, part 3): the built-in multispectral
// plans, plan files an operator writes (validated, the bad field named), the
// capture builder pairing any plan's whites and subjects, and the plan
// measurement (R, G, B albedo per capture against its own white).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>

#include "chromo/calibration/led_library.hpp"
#include "chromo/session/method_measurement.hpp"
#include "chromo/session/session_captures.hpp"
#include "chromo/session/session_plan.hpp"
#include "chromo/spectral/cie.hpp"
#include "chromo/spectral/lab_illuminants.hpp"

namespace chromo::session {
namespace {

namespace fs = std::filesystem;

TEST(Plans, MultispectralPlanLightsEachLedTypeAloneWithItsWhite) {
  const SessionPlan plan = multispectral_plan();
  std::string error;
  ASSERT_TRUE(plan.IsValid(&error)) << error;
  ASSERT_EQ(plan.steps.size(), 13u);  // dark, 6 whites, 6 subjects
  EXPECT_EQ(plan.steps[0].role, StepRole::kDark);
  for (int k = 0; k < 6; ++k) {
    const Step& white = plan.steps[1 + k];
    const Step& subject = plan.steps[7 + k];
    EXPECT_EQ(white.role, StepRole::kWhite);
    EXPECT_EQ(subject.role, StepRole::kSubject);
    ASSERT_EQ(subject.illumination.kind, Illumination::Kind::kWeights);
    for (int led = 0; led < 6; ++led) {
      EXPECT_EQ(subject.illumination.weights[led], led == k ? 1.0 : 0.0);
      EXPECT_EQ(white.illumination.weights[led], subject.illumination.weights[led]);
    }
  }
  const PlanTiming t = plan_timing(plan);
  EXPECT_EQ(t.captures, 6);
  EXPECT_EQ(t.channels, 18);
  // 6 subject steps of 50 ms settle + 20 ms exposure; 7 reference steps apart.
  EXPECT_NEAR(t.subject_time_s, 6 * 0.07, 1e-9);
  EXPECT_NEAR(t.reference_time_s, 7 * 0.07, 1e-9);

  const SessionPlan both = multispectral_plan({}, true);
  EXPECT_EQ(plan_timing(both).captures, 9);
  EXPECT_EQ(plan_timing(both).channels, 27);
  EXPECT_EQ(plan_timing(standard_plan()).channels, 4);  // the method's: D65' R, G, B and the blue-only B
  EXPECT_EQ(builtin_plan_names().size(), 3u);
  for (const std::string& name : builtin_plan_names()) EXPECT_EQ(builtin_plan(name)->name, name);
  EXPECT_FALSE(builtin_plan("nonesuch").has_value());
}

class PlanFile : public ::testing::Test {
 protected:
  fs::path dir = fs::temp_directory_path() / ("chromo_plan_file_test_" + std::to_string(::getpid()));
  void SetUp() override { fs::create_directories(dir); }
  void TearDown() override { fs::remove_all(dir); }
  std::string write(const std::string& name, const std::string& text) {
    const fs::path path = dir / name;
    std::ofstream(path) << text;
    return path.string();
  }
  std::string error_of(const std::string& text) {
    try {
      read_plan_file(write("plan.json", text));
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "";
  }
};

TEST_F(PlanFile, AValidFileReadsBackAsWritten) {
  const std::string path = write("ms.json", to_json(multispectral_plan()).dump());
  const SessionPlan plan = read_plan_file(path);
  EXPECT_EQ(to_json(plan), to_json(multispectral_plan()));
  // The "plan" member of a session.json is accepted too.
  const std::string wrapped = write("session.json", nlohmann::json{{"plan", to_json(standard_plan())}}.dump());
  EXPECT_EQ(read_plan_file(wrapped).steps.size(), 7u);
}

TEST_F(PlanFile, BadFieldsAreRefusedByName) {
  nlohmann::json plan = to_json(multispectral_plan());
  plan["steps"][3]["illumination"]["weights"]["Blue"] = 1.0;  // not an LED type name (B)
  EXPECT_NE(error_of(plan.dump()).find("steps[3].illumination.weights.Blue"), std::string::npos) << error_of(plan.dump());

  plan = to_json(multispectral_plan());
  plan["steps"][2]["exposure_us"] = 0;
  EXPECT_NE(error_of(plan.dump()).find("steps[2].exposure_us"), std::string::npos) << error_of(plan.dump());

  plan = to_json(multispectral_plan());
  plan["steps"][5]["illumination"]["weights"]["R"] = 1.5;
  EXPECT_NE(error_of(plan.dump()).find("steps[5].weights.R"), std::string::npos) << error_of(plan.dump());

  plan = to_json(multispectral_plan());
  plan["steps"][1]["role"] = "reference";
  EXPECT_NE(error_of(plan.dump()).find("steps[1].role"), std::string::npos);

  plan = to_json(multispectral_plan());
  plan["steps"][4].erase("illumination");
  EXPECT_NE(error_of(plan.dump()).find("steps[4].illumination"), std::string::npos);

  EXPECT_NE(error_of("{not json").find("not valid JSON"), std::string::npos);
  EXPECT_NE(error_of("[]").find("plan: not a JSON object"), std::string::npos);
  try {
    read_plan_file((dir / "missing.json").string());
    ADD_FAILURE() << "a missing file was read";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("missing.json"), std::string::npos);
  }
}

TEST(PlanCaptureBuilder, PairsWhitesAndSubjectsByIllumination) {
  CaptureSources sources;
  sources.camera = spectral::builtin_camera("nikon_d5100");
  const SessionCaptureBuilder multispectral(multispectral_plan(), sources);
  EXPECT_FALSE(multispectral.is_standard_plan());
  EXPECT_TRUE(SessionCaptureBuilder(standard_plan(), sources).is_standard_plan());
  EXPECT_FALSE(SessionCaptureBuilder(multispectral_plan({}, true), sources).is_standard_plan());
  // The polarised standard plan is the method's (cross) plus D65' parallel, which
  // captures() returns as Captures::parallel; a parallel capture of another mix is not.
  EXPECT_TRUE(SessionCaptureBuilder(standard_plan({.polarised = true}), sources).is_standard_plan());
  SessionPlan w57_parallel = standard_plan({.polarised = true});
  for (Step& step : w57_parallel.steps)
    if (step.name.ends_with("_d65_parallel")) step.illumination.mix = "w57";
  EXPECT_FALSE(SessionCaptureBuilder(w57_parallel, sources).is_standard_plan());
  // A subject without its white, a white without its subject, an unlit subject: refused, named.
  SessionPlan plan = multispectral_plan();
  plan.steps.erase(plan.steps.begin() + 2);  // white_W40
  try {
    SessionCaptureBuilder builder(plan, sources);
    ADD_FAILURE() << "a subject without its white was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("subject_W40"), std::string::npos) << e.what();
  }
  plan = multispectral_plan();
  plan.steps[8].illumination.weights = {};
  try {
    SessionCaptureBuilder builder(plan, sources);
    ADD_FAILURE() << "an unlit subject was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(plan.steps[8].name), std::string::npos) << e.what();
  }
  EXPECT_THROW(multispectral.captures(), std::logic_error);  // no frames yet
}

// One camera's frame of a step: every sample `value` (of full scale 4095 for
// BayerRG12 in 16-bit samples, 255 for RGB8).
struct TestFrame {
  FrameRecord record;
  std::vector<std::uint8_t> samples;
};
TestFrame test_frame(const Step& step, const std::string& camera, drivers::PixelFormat format, int width, int height,
                     int value, double exposure_us) {
  TestFrame f;
  f.record.step = step.name;
  f.record.role = step.role;
  f.record.camera = camera;
  f.record.width = width;
  f.record.height = height;
  f.record.pixel_format = format;
  f.record.exposure_us = exposure_us;
  FrameLedState led;
  if (step.illumination.kind == Illumination::Kind::kWeights) led.drive = step.illumination.weights;
  else if (step.illumination.kind == Illumination::Kind::kMix) led.drive = {0.8, 0, 0, 0.05, 0.1, 0.25};
  f.record.led = led;
  const auto& info = drivers::pixel_format_info(format);
  const std::size_t count = static_cast<std::size_t>(width) * height * info.samples_per_pixel;
  if (info.bytes_per_sample == 1) {
    f.samples.assign(count, static_cast<std::uint8_t>(value));
  } else {
    const auto v = static_cast<std::uint16_t>(value);
    f.samples.resize(2 * count);
    for (std::size_t i = 0; i < count; ++i) std::memcpy(f.samples.data() + 2 * i, &v, 2);
  }
  return f;
}

// Two cameras of different sensors, formats and exposures, their frames
// interleaved step by step: each camera's captures hold its frames only,
// under the method's plan and under a multispectral one alike.
TEST(PlanCaptureBuilder, KeepsEachCameraApartUnderAnyPlan) {
  CaptureSources sources;
  sources.camera = spectral::builtin_camera("nikon_d5100");
  sources.led_library = calibration::nominal_led_library();
  for (const SessionPlan& plan : {standard_plan(), multispectral_plan()}) {
    SCOPED_TRACE(plan.name);
    SessionCaptureBuilder builder(plan, sources);
    // Camera "a": 8x6 BayerRG12 at 1000 us, value 100 + 10·step; "b": 5x3 RGB8 at 3000 us, value 50 + 3·step.
    auto value_a = [](std::size_t k) { return 100 + 10 * static_cast<int>(k); };
    auto value_b = [](std::size_t k) { return 50 + 3 * static_cast<int>(k); };
    for (std::size_t k = 0; k < plan.steps.size(); ++k) {
      const Step& step = plan.steps[k];
      for (std::uint32_t n = 0; n < step.frames_per_camera; ++n) {
        const auto a = test_frame(step, "a", drivers::PixelFormat::kBayerRG12, 8, 6, value_a(k), 1000);
        builder.add_frame(a.record, a.samples);
        if (k + 1 == plan.steps.size()) continue;  // "b" misses the last step's frames for now
        const auto b = test_frame(step, "b", drivers::PixelFormat::kRgb8, 5, 3, value_b(k), 3000);
        builder.add_frame(b.record, b.samples);
      }
    }
    ASSERT_EQ(builder.cameras(), (std::vector<std::string>{"a", "b"}));
    EXPECT_EQ(builder.camera(), "a");
    EXPECT_TRUE(builder.complete("a"));
    EXPECT_TRUE(builder.references_complete("b"));
    EXPECT_FALSE(builder.complete("b"));
    EXPECT_EQ(builder.missing("b"),
              plan.steps.back().name + ": 0 of " + std::to_string(plan.steps.back().frames_per_camera) + " frames");
    EXPECT_FALSE(builder.references_complete("c"));  // no frames at all
    // A frame that cannot be used is refused naming its camera, and adds no camera.
    const auto mono = test_frame(plan.steps[0], "c", drivers::PixelFormat::kMono12, 8, 6, 7, 1000);
    try {
      builder.add_frame(mono.record, mono.samples);
      ADD_FAILURE() << "a mono frame was accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("(camera c)"), std::string::npos) << e.what();
    }
    EXPECT_EQ(builder.cameras().size(), 2u);
    const auto last = test_frame(plan.steps.back(), "b", drivers::PixelFormat::kRgb8, 5, 3,
                                 value_b(plan.steps.size() - 1), 3000);
    for (std::uint32_t n = 0; n < plan.steps.back().frames_per_camera; ++n) builder.add_frame(last.record, last.samples);
    EXPECT_TRUE(builder.complete("b"));

    std::map<std::string, std::size_t> index_of;
    for (std::size_t k = 0; k < plan.steps.size(); ++k) index_of[plan.steps[k].name] = k;
    std::size_t dark = 0;
    while (plan.steps[dark].role != StepRole::kDark) ++dark;
    for (const std::string camera : {"a", "b"}) {
      const Captures captures = builder.captures(camera);
      const bool is_a = camera == "a";
      const double full = is_a ? 4095 : 255;
      auto value = [&](std::size_t k) { return (is_a ? value_a(k) : value_b(k)) / full; };
      EXPECT_EQ(captures.dark.width, is_a ? 4 : 5);  // Bayer binned 2x2; RGB as is
      EXPECT_EQ(captures.dark.height, 3);
      EXPECT_FLOAT_EQ(captures.dark.planes[1][0], static_cast<float>(value(dark)));
      std::size_t subjects = 0;
      for (const Step& step : plan.steps) subjects += step.role == StepRole::kSubject;
      ASSERT_EQ(captures.captures.size(), subjects);
      for (const IlluminatedCapture& capture : captures.captures) {
        // Each capture's white and subject are the camera's own frames of the paired steps.
        std::size_t subject = 0, white = 0;
        for (std::size_t k = 0; k < plan.steps.size(); ++k) {
          if (plan.steps[k].role == StepRole::kDark) continue;
          if (capture_name(illumination_state(plan.steps[k])) != capture.name) continue;
          (plan.steps[k].role == StepRole::kSubject ? subject : white) = k;
        }
        EXPECT_FLOAT_EQ(capture.subject.planes[0][0], static_cast<float>(value(subject))) << capture.name;
        EXPECT_FLOAT_EQ(capture.white.planes[2].back(), static_cast<float>(value(white))) << capture.name;
        EXPECT_EQ(capture.subject.exposure_us, is_a ? 1000 : 3000);
        EXPECT_EQ(capture.white.width, is_a ? 4 : 5);
      }
    }
    // The standard plan's captures carry its recipe (D65', W57, W57+blue in that order), any other the default.
    EXPECT_EQ(builder.captures().recipe.channels.size(), builder.is_standard_plan() ? 4u : 0u);
    EXPECT_EQ(builder.captures("a").captures.front().name, builder.is_standard_plan() ? "D65'" : "W57");
    EXPECT_FLOAT_EQ(builder.captures().captures[0].subject.planes[0][0],
                    builder.captures("a").captures[0].subject.planes[0][0]);
    EXPECT_EQ(builder.captures("b").captures[0].subject.width, 5);
    EXPECT_THROW(builder.captures("c"), std::logic_error);
  }
}

// The LEDs' temperatures (docs/calibration.md "The thermal model"): with a
// library whose LEDs lose 0.4 % of flux per kelvin (measured at 60 °C) and
// frames that record their temperatures at the trigger, a white taken at
// 60 °C and its subject at 40 °C: the subject's light is 8 % brighter, so
// the white's signal is to be scaled by 1.08 in every channel, the white's
// pixels left as taken (its saturation check sees them raw) and the
// capture's illuminant the white's (the tables prepared from it serve).
// Records without per-trigger temperatures are left as they were.
TEST(PlanCaptureBuilder, AWhiteTakenWarmerIsPutUnderTheSubjectsLight) {
  CaptureSources sources;
  sources.camera = spectral::builtin_camera("nikon_d5100");
  sources.led_library = calibration::nominal_led_library();
  for (auto& led : sources.led_library.leds) {
    for (auto& rung : led.ladder) rung.led_temperature_C = 60.0;
    led.thermal = calibration::LedThermalRecord{1.0, 25.0, 60.0, -0.004, 0.0};
  }
  const SessionPlan plan = multispectral_plan();
  for (const bool at_trigger : {true, false}) {
    SCOPED_TRACE(at_trigger ? "temperatures at the trigger" : "the step's first reading");
    SessionCaptureBuilder builder(plan, sources);
    std::size_t dark = 0;
    for (std::size_t k = 0; k < plan.steps.size(); ++k) {
      const Step& step = plan.steps[k];
      if (step.role == StepRole::kDark) dark = k;
      TestFrame f = test_frame(step, "a", drivers::PixelFormat::kBayerRG12, 8, 6, 100 + 10 * static_cast<int>(k), 1000);
      f.record.led->temperature_C.fill(step.role == StepRole::kWhite ? 60.0 : 40.0);
      f.record.led->temperatures_at_trigger = at_trigger;
      for (std::uint32_t n = 0; n < step.frames_per_camera; ++n) builder.add_frame(f.record, f.samples);
    }
    const double gain = at_trigger ? 1.0 + -0.004 * (40.0 - 60.0) : 1.0;
    const Captures captures = builder.captures("a");
    for (const IlluminatedCapture& capture : captures.captures) {
      std::size_t white = 0;
      spectral::Spectrum subject_light;
      for (std::size_t k = 0; k < plan.steps.size(); ++k) {
        if (plan.steps[k].role == StepRole::kDark || capture_name(illumination_state(plan.steps[k])) != capture.name)
          continue;
        if (plan.steps[k].role == StepRole::kWhite) white = k;
        for (auto type : spectral::kAllLedTypes) {
          const auto i = static_cast<std::size_t>(spectral::led_type_index(type));
          if (plan.steps[k].role == StepRole::kSubject)
            subject_light += sources.led_library.led(type).spectrum_per_unit_drive() *
                             (plan.steps[k].illumination.weights[i] * gain);
        }
      }
      const double raw_white = (100 + 10 * static_cast<int>(white)) / 4095.0;
      for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(capture.white.planes[c][0], raw_white, 1e-6) << capture.name << " channel " << c;
        EXPECT_NEAR(capture.white_signal_scale[c], gain, 1e-9) << capture.name << " channel " << c;
      }
      for (int i = 0; i < spectral::kGridSize; i += 10)  // the white's light: the subject's over the gain
        EXPECT_NEAR(capture.illuminant[i], subject_light[i] / gain, 1e-9 * (1 + subject_light[i])) << capture.name;
    }
  }
}

// The main job's frame counts (4 frames per white, 1 per subject) at the
// levels its D65' mix applied: a capture's illuminant from its references
// alone equals, bit for bit, the one from references and subject, so chromod's
// tables prepared during capture serve the estimate (issue 39; the mean of
// 5 equal spectra differed from 4's in the last bit and the inverse table was
// rebuilt after the last frame: 4.0 s). A subject under other levels keeps
// its white's light and scales the white's signal instead.
TEST(PlanCaptureBuilder, IlluminantFromTheReferencesIsTheEstimatesWhenTheLevelsAreTheSame) {
  CaptureSources sources;
  sources.camera = spectral::builtin_camera("nikon_d5100");
  sources.led_library = calibration::nominal_led_library();
  SessionPlan plan = standard_plan();
  for (Step& step : plan.steps) step.frames_per_camera = step.role == StepRole::kSubject ? 1 : 4;
  const std::array<double, 6> d65_drive = {1.0, 0, 0, 0.17470054169527732, 0.491630426489662, 0.864438849469749};
  SessionCaptureBuilder builder(plan, sources);
  auto add_steps = [&](bool subjects, const std::string& camera, double subject_drive_factor) {
    for (const Step& step : plan.steps) {
      if ((step.role == StepRole::kSubject) != subjects) continue;
      auto frame = test_frame(step, camera, drivers::PixelFormat::kBayerRG12, 8, 6,
                              step.role == StepRole::kDark ? 100 : 2000 + 500 * (step.name.find("blue") != std::string::npos),
                              1000);
      const auto ends_with = [&](const std::string& mix) {
        return step.name.size() >= mix.size() && step.name.compare(step.name.size() - mix.size(), mix.size(), mix) == 0;
      };
      if (ends_with("w57+blue")) frame.record.led->drive = {0.025192645151445793, 0, 0, 0, 0, 1.0};
      else if (ends_with("w57")) frame.record.led->drive = {0.025192645151445793, 0, 0, 0, 0, 0};
      else if (ends_with("d65")) {
        frame.record.led->drive = d65_drive;
        if (step.role == StepRole::kSubject)
          for (double& d : frame.record.led->drive) d *= subject_drive_factor;
      }
      for (std::uint32_t n = 0; n < step.frames_per_camera; ++n) builder.add_frame(frame.record, frame.samples);
    }
  };
  add_steps(false, "a", 1.0);
  add_steps(false, "b", 1.0);
  ASSERT_TRUE(builder.references_complete("a"));
  const estimation::MeasurementSet from_references = measurement_set_from_references(builder.captures("a"));
  add_steps(true, "a", 1.0);
  add_steps(true, "b", 0.9);  // camera b's D65' subject under 10% less light
  ASSERT_TRUE(builder.complete("a"));
  const estimation::MeasurementSet at_the_end = measurement_set_from_references(builder.captures("a"));
  ASSERT_EQ(from_references.channels.size(), at_the_end.channels.size());
  for (std::size_t c = 0; c < at_the_end.channels.size(); ++c) {
    const auto &x = from_references.channels[c], &y = at_the_end.channels[c];
    EXPECT_TRUE((x.illuminant.values() == y.illuminant.values()).all()) << x.name;
    EXPECT_EQ(x.noise.read_sigma, y.noise.read_sigma) << x.name;
    EXPECT_EQ(x.noise.shot_coefficient, y.noise.shot_coefficient) << x.name;
  }
  const IlluminatedCapture same = builder.captures("a").captures[0], moved = builder.captures("b").captures[0];
  // Camera b's subject under 0.9 of its white's light: the capture keeps the
  // white's light, and the white's signal is scaled by 0.9 where the albedo
  // is formed (the subject's albedo is then its response to its own light).
  EXPECT_TRUE((moved.illuminant.values() == same.illuminant.values()).all());
  for (int c = 0; c < 3; ++c) {
    EXPECT_EQ(same.white_signal_scale[c], 1.0);
    EXPECT_NEAR(moved.white_signal_scale[c], 0.9, 1e-12) << "channel " << c;
  }
}

// One sum (issue 36): a builder reading the sums another thread filled (the
// daemon's storage thread) gives exactly the captures of a builder summing the
// same frames itself; a step's sum is read only once its frames are all in,
// and a sum that lacks a frame the builder counted is refused naming the step.
TEST(PlanCaptureBuilder, ReadsTheStoredSumsAsItsOwnSum) {
  CaptureSources sources;
  sources.camera = spectral::builtin_camera("nikon_d5100");
  sources.led_library = calibration::nominal_led_library();
  StandardPlanOptions two_frames;
  two_frames.frames_per_camera = 2;
  const SessionPlan plan = standard_plan(two_frames);
  const auto stored = std::make_shared<SessionFrameSums>();
  const auto lacking = std::make_shared<SessionFrameSums>();  // a storage thread that refused one frame
  SessionCaptureBuilder own(plan, sources), reading(plan, sources, stored), reading_lacking(plan, sources, lacking);
  EXPECT_THROW(reading.add_frame(test_frame(plan.steps[0], "a", drivers::PixelFormat::kBayerRG12, 8, 6, 1, 1000).record, {}),
               std::logic_error);
  const std::string refused_step = plan.steps.back().name;
  for (std::size_t k = 0; k < plan.steps.size(); ++k)
    for (std::uint32_t n = 0; n < plan.steps[k].frames_per_camera; ++n)
      for (const auto& f : {test_frame(plan.steps[k], "a", drivers::PixelFormat::kBayerRG12, 8, 6, 100 + 10 * int(k) + int(n), 1000),
                            test_frame(plan.steps[k], "b", drivers::PixelFormat::kRgb8, 5, 3, 50 + 3 * int(k) + int(n), 3000)}) {
        stored->add(f.record, f.samples);
        if (!(f.record.step == refused_step && f.record.camera == "a" && n == 1)) lacking->add(f.record, f.samples);
        own.add_frame(f.record, f.samples);
        reading.add_summed_frame(f.record);
        reading_lacking.add_summed_frame(f.record);
        if (k + 1 == plan.steps.size() && n == 0 && f.record.camera == "a") {
          // The last step has half its frames: its image stays empty until the sum is whole.
          EXPECT_EQ(reading.captures("a").captures[2].subject.width, 0);
          EXPECT_TRUE(reading.captures("a").captures[2].subject.planes[0].empty());
          EXPECT_EQ(reading.captures("a").captures[2].white.width, 4);
        }
      }
  for (const std::string camera : {"a", "b"}) {
    SCOPED_TRACE(camera);
    const Captures a = own.captures(camera), b = reading.captures(camera);
    for (const auto& [x, y] : {std::pair{&a.captures[0], &b.captures[0]}, {&a.captures[1], &b.captures[1]},
                               {&a.captures[2], &b.captures[2]}}) {
      EXPECT_EQ(y->subject.frames, 2u);
      for (int c = 0; c < 3; ++c) {
        EXPECT_EQ(x->subject.planes[c], y->subject.planes[c]);
        EXPECT_EQ(x->white.planes[c], y->white.planes[c]);
      }
      EXPECT_TRUE((x->illuminant.values() == y->illuminant.values()).all());
    }
    for (int c = 0; c < 3; ++c) EXPECT_EQ(a.dark.planes[c], b.dark.planes[c]);
  }
  EXPECT_FLOAT_EQ(reading.captures("b").dark.planes[0][0], static_cast<float>(50 + 0.5) / 255);  // (50 + 51) / 2
  try {
    reading_lacking.captures("a");
    ADD_FAILURE() << "a sum lacking a counted frame was read";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("step " + refused_step + " (camera a)"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(reading_lacking.captures("b"));
}

RgbImage flat(int width, int height, std::array<float, 3> value) {
  RgbImage image;
  image.width = width, image.height = height;
  for (int c = 0; c < 3; ++c) image.planes[c].assign(image.pixels(), value[c]);
  return image;
}

// Albedo per capture and camera channel is ρ·(subject − dark)/(white − dark),
// each capture against its own white; the set's channels carry each capture's
// illuminant, in plan order.
TEST(PlanMeasurement, EveryCaptureIsNormalisedByItsOwnWhite) {
  Captures captures;
  captures.camera = spectral::builtin_camera("nikon_d5100");
  captures.white_reflectance = 0.9;
  const int w = 24, h = 16;
  captures.dark = flat(w, h, {0.02f, 0.02f, 0.02f});
  // The subject carries a texture (the registration needs structure); the whites are flat.
  auto texture = [](int x, int y) { return 1.0f + 0.3f * std::sin(x / 2.0f) * std::cos(y / 1.5f); };
  for (int k = 0; k < 6; ++k) {
    const auto type = spectral::kAllLedTypes[k];
    IlluminatedCapture c;
    c.name = std::string(spectral::led_type_name(type));
    c.illuminant = spectral::led_spectrum(type);
    const float scale = 0.3f + 0.1f * k;
    c.white = flat(w, h, {0.02f + 0.6f * scale, 0.02f + 0.5f * scale, 0.02f + 0.4f * scale});
    c.subject = flat(w, h, {0, 0, 0});
    const float ratio[3] = {0.5f, 0.2f, 0.5f};
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        for (int ch = 0; ch < 3; ++ch)
          c.subject.planes[ch][y * w + x] = 0.02f + (c.white.planes[ch][0] - 0.02f) * ratio[ch] * texture(x, y);
    captures.captures.push_back(c);
  }
  RegistrationOptions registration;
  const Measurement m = build_measurement(captures, registration);
  ASSERT_EQ(m.set.size(), 18);
  {  // A white's signal scaled (the LEDs' temperatures, white_signal_scale): its capture's albedo divided by it.
    Captures scaled = captures;
    scaled.captures[1].white_signal_scale = {1.25, 1.1, 1.0};
    const Measurement s = build_measurement(scaled, registration);
    for (std::size_t pixel = 0; pixel < 5; ++pixel)
      for (int ch = 0; ch < 3; ++ch) {
        EXPECT_NEAR(s.measured[pixel * 18 + 3 + ch] * scaled.captures[1].white_signal_scale[ch],
                    m.measured[pixel * 18 + 3 + ch], 1e-5) << "channel " << ch;
        EXPECT_EQ(s.measured[pixel * 18 + ch], m.measured[pixel * 18 + ch]);  // the other captures as they were
      }
  }
  EXPECT_EQ(m.set.channels[0].name, "W57.R");
  EXPECT_EQ(m.set.channels[17].name, "B.B");
  EXPECT_EQ(m.photographs.size(), 6u);
  ASSERT_EQ(m.measured.size(), static_cast<std::size_t>(w * h * 18));
  for (int k = 0; k < 6; ++k) {
    EXPECT_EQ(m.set.channels[3 * k].illuminant.values().maxCoeff(), captures.captures[k].illuminant.values().maxCoeff());
    EXPECT_FALSE(k > 0 && m.registration[k - 1].warped);  // nothing moved
    // Subject/white signal ratios 0.5, 0.2, 0.5 (times the texture) of any scale, times ρ.
    for (int pixel : {0, 5 * w + 7, w * h - 1}) {
      const double t = texture(pixel % w, pixel / w);
      EXPECT_NEAR(m.measured[pixel * 18 + 3 * k + 0], 0.9 * 0.5 * t, 1e-5);
      EXPECT_NEAR(m.measured[pixel * 18 + 3 * k + 1], 0.9 * 0.2 * t, 1e-5);
      EXPECT_NEAR(m.measured[pixel * 18 + 3 * k + 2], 0.9 * 0.5 * t, 1e-5);
    }
  }
  EXPECT_EQ(measurement_set_from_references(captures).size(), 18);
  // No capture: refused.
  captures.captures.clear();
  EXPECT_THROW(build_measurement(captures), std::invalid_argument);
}

// One route: the standard plan's channels are a recipe over the same
// captures. Its D65' channels are the default recipe's first three values
// exactly, its blue channel the white-weighted difference of the W57+blue
// and W57 albedos in B, the photographs the same; a recipe naming a capture
// the captures lack is refused, named.
TEST(PlanMeasurement, TheStandardRecipeIsARecipeOverTheSameCaptures) {
  Captures captures;
  captures.camera = spectral::builtin_camera("nikon_d5100");
  const int w = 20, h = 12;
  captures.dark = flat(w, h, {0.02f, 0.02f, 0.02f});
  const spectral::Spectrum w57 = spectral::led_spectrum(spectral::LedType::kW57);
  const std::pair<const char*, spectral::Spectrum> lights[] = {
      {"D65'", spectral::illuminant_d65()}, {"W57", w57}, {"W57+blue", w57 + spectral::led_spectrum(spectral::LedType::kBlue)}};
  for (int k = 0; k < 3; ++k) {
    IlluminatedCapture c;
    c.name = lights[k].first;
    c.illuminant = lights[k].second;
    c.white = flat(w, h, {0.5f, 0.55f, k == 2 ? 0.75f : 0.4f});
    c.subject = flat(w, h, {0, 0, 0});
    for (int i = 0; i < w * h; ++i)
      for (int ch = 0; ch < 3; ++ch)
        c.subject.planes[ch][i] = 0.02f + (c.white.planes[ch][0] - 0.02f) * (0.3f + 0.01f * ((i * 7 + ch) % 13));
    captures.captures.push_back(c);
  }
  const Measurement every = build_measurement(captures);
  Captures standard = captures;
  standard.recipe = standard_recipe();
  const Measurement m = build_measurement(standard);
  ASSERT_EQ(every.set.size(), 9);
  ASSERT_EQ(m.set.size(), 4);
  EXPECT_EQ(m.set.channels[3].name, "blue.B");
  EXPECT_EQ(m.registration.size(), 2u);
  EXPECT_EQ(m.registration[0].channel, "G");
  const float w_mix = 0.75f - 0.02f, w_base = 0.4f - 0.02f;
  for (int i = 0; i < w * h; ++i) {
    for (int c = 0; c < 3; ++c) {
      EXPECT_EQ(m.measured[i * 4 + c], every.measured[i * 9 + c]) << i;
      EXPECT_EQ(m.set.channels[c].noise.read_sigma, every.set.channels[c].noise.read_sigma);
    }
    const float blue = (every.measured[i * 9 + 8] * w_mix - every.measured[i * 9 + 5] * w_base) / (w_mix - w_base);
    EXPECT_NEAR(m.measured[i * 4 + 3], blue, 1e-5) << i;
  }
  ASSERT_EQ(m.photographs.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) EXPECT_EQ(m.photographs[k].rgb, every.photographs[k].rgb) << k;
  standard.recipe.channels.push_back({5, 1, std::nullopt, {}});
  try {
    build_measurement(standard);
    ADD_FAILURE() << "a recipe naming a sixth capture was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("recipe channel 4"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace chromo::session
