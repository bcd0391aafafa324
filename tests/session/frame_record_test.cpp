// The typed frame path: FrameRecord and its journal JSON (frame_record.hpp),
// the frame sums (frame_sums.hpp), and the same captures and derived data
// from frames added live and from the same frames read back from the folder.
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>

#include "../support/fresh_directory.hpp"
#include "../support/session_sample.hpp"
#include "chromo/files/float_image.hpp"
#include "chromo/session/derived_data.hpp"
#include "chromo/session/frame_files.hpp"
#include "chromo/session/frame_record.hpp"
#include "chromo/session/frame_sums.hpp"
#include "chromo/session/session_captures.hpp"
#include "chromo/session/session_store.hpp"

namespace chromo::session {
namespace {

namespace fs = std::filesystem;

FrameRecord full_record() {
  FrameRecord r;
  r.index = 12;
  r.file = "frames/white_w57/cam1-000042.tiff";
  r.step = "white_w57";
  r.step_index = 2;
  r.role = StepRole::kWhite;
  r.frame_in_step = 3;
  r.exposure_us = 12500.5;
  FrameLedState led;
  led.drive = {1.0, 0, 0.25, 0.125, 0.5, 0.8678416113527123};
  led.requested_drive = {1.0, 0, 0.25, 0.125, 0.5, 0.8678403055105451};
  led.temperature_C = {25.01, 25.03, 25.15, 25.6, 28.26, 40.32};
  led.channel_faults = {0, 0, 4, 0, 0, 1};
  led.controller_faults = 2;
  led.sequence_position = 7;
  led.temperatures_at_trigger = true;
  r.led = led;
  r.camera = "cam1";
  r.sequence = 42;
  r.camera_frame_id = 65402;
  r.camera_timestamp_ns = 1796185667800005000ull;
  r.trigger_id = 318;
  r.camera_trigger_count = 17;
  r.host_timestamp_ns = 1796185667802151000ll;
  r.width = 192;
  r.height = 144;
  r.pixel_format = drivers::PixelFormat::kBayerRG12;
  return r;
}

TEST(FrameRecord, JournalRecordRoundTripsEveryField) {
  const FrameRecord record = full_record();
  const nlohmann::json json = to_json(record);
  EXPECT_EQ(json["type"], "frame");
  EXPECT_EQ(json["pixel_format"], "BayerRG12");
  EXPECT_EQ(json["role"], "white");
  EXPECT_EQ(json["trigger_id"], 318);
  EXPECT_EQ(json["camera_trigger_count"], 17);
  EXPECT_EQ(json["led"]["drive"]["B"], 0.8678416113527123);
  EXPECT_EQ(json["led"]["drive"]["W27"], 0.25);
  EXPECT_EQ(frame_record_from_json(json), record);
  // Through text, as the journal stores it.
  EXPECT_EQ(frame_record_from_json(nlohmann::json::parse(json.dump())), record);
  // A record without LED state stays without.
  FrameRecord dark = record;
  dark.led.reset();
  EXPECT_FALSE(to_json(dark).contains("led"));
  EXPECT_EQ(frame_record_from_json(to_json(dark)), dark);
}

// Every frame record of the committed format-1 folder reads into the typed
// record and writes back as the same JSON (less the journal's "t").
TEST(FrameRecord, FormatOneRecordsReadAndWriteBackUnchanged) {
  int frames = 0;
  for (auto json : read_journal(testing::kSessionFormatOneSample / "journal.jsonl").records) {
    if (json.value("type", "") != "frame") continue;
    ++frames;
    const FrameRecord record = frame_record_from_json(json);
    json.erase("t");
    EXPECT_EQ(to_json(record), json) << json.dump();
    ASSERT_TRUE(record.led);
    EXPECT_EQ(record.pixel_format, drivers::PixelFormat::kBayerRG12);
    EXPECT_EQ(record.trigger_id, 0u);  // written before triggers were numbered
    EXPECT_EQ(record.led->polarisation, drivers::PolarisationPerType{});  // written before polarisation: unpolarised
  }
  EXPECT_EQ(frames, 7);
}

TEST(FrameRecord, PolarisationIsRecordedPerLedTypeAndAbsentWhenUnpolarised) {
  FrameRecord record = full_record();
  EXPECT_FALSE(to_json(record)["led"].contains("polarisation"));  // unpolarised: as before polarisation
  record.led->polarisation[static_cast<std::size_t>(spectral::led_type_index(spectral::LedType::kW57))] =
      drivers::Polarisation::kParallel;
  record.led->polarisation[static_cast<std::size_t>(spectral::led_type_index(spectral::LedType::kBlue))] =
      drivers::Polarisation::kCross;
  const nlohmann::json json = to_json(record);
  EXPECT_EQ(json["led"]["polarisation"], (nlohmann::json{{"W57", "parallel"}, {"B", "cross"}}));
  const FrameRecord back = frame_record_from_json(nlohmann::json::parse(json.dump()));
  EXPECT_EQ(back, record);
  EXPECT_EQ(back.led->polarisation[static_cast<std::size_t>(spectral::led_type_index(spectral::LedType::kW40))],
            drivers::Polarisation::kUnpolarised);
}

TEST(FrameRecord, BadRecordsAreRefusedNamingTheField) {
  auto refused = [](nlohmann::json json, const std::string& field) {
    try {
      frame_record_from_json(json);
      ADD_FAILURE() << "accepted " << json.dump();
    } catch (const std::invalid_argument& error) {
      EXPECT_NE(std::string(error.what()).find(field), std::string::npos) << error.what();
    }
  };
  const nlohmann::json good = to_json(full_record());
  nlohmann::json j = good;
  j.erase("file");
  refused(j, "file: missing");
  j = good;
  j["pixel_format"] = "BayerGB8";
  refused(j, "pixel_format: \"BayerGB8\" unknown");
  j = good;
  j["led"]["drive"]["UV"] = 0.5;
  refused(j, "led.drive.UV");
  j = good;
  j["width"] = "wide";
  refused(j, "width: not a number");
  j = good;
  j["led"]["temperature_C"] = {1, 2};
  refused(j, "led.temperature_C");
  j = good;
  j["led"]["temperatures_at"] = "step";
  refused(j, "led.temperatures_at");
  j = good;
  j["role"] = "flat";
  refused(j, "role");
  j = good;
  j["led"]["polarisation"] = {{"W57", "diagonal"}};
  refused(j, "led.polarisation.W57: \"diagonal\" is not unpolarised, cross or parallel");
  j = good;
  j["led"]["polarisation"] = {{"UV", "cross"}};
  refused(j, "led.polarisation.UV");
  j = good;
  j["led"]["polarisation"] = "cross";
  refused(j, "led.polarisation: not an object");
}

TEST(FrameSums, SumsExactlyAndMeansInUnitsOfFullScale) {
  FrameRecord record;
  record.step = "s";
  record.camera = "c";
  record.width = 2, record.height = 1;
  record.pixel_format = drivers::PixelFormat::kMono12;
  FrameSums sums;
  const std::uint16_t a[2] = {4095, 1}, b[2] = {0, 2};
  sums.add(record, {reinterpret_cast<const std::uint8_t*>(a), 4});
  sums.add(record, {reinterpret_cast<const std::uint8_t*>(b), 4});
  EXPECT_EQ(sums.frames(), 2u);
  EXPECT_EQ(sums.sums(), (std::vector<std::uint32_t>{4095, 3}));
  EXPECT_DOUBLE_EQ(sums.mean(0), 0.5);
  EXPECT_DOUBLE_EQ(sums.mean(1), 3.0 / (2 * 4095.0));
  // A frame of another size or format in the same step is refused, nothing added.
  FrameRecord other = record;
  other.pixel_format = drivers::PixelFormat::kMono16;
  EXPECT_THROW(sums.add(other, {reinterpret_cast<const std::uint8_t*>(a), 4}), std::invalid_argument);
  EXPECT_THROW(sums.add(record, {reinterpret_cast<const std::uint8_t*>(a), 3}), std::invalid_argument);
  EXPECT_EQ(sums.frames(), 2u);
}

// Two cameras, two BayerRG12 frames per step of the standard plan: what the
// daemon accumulates live (frames in memory) and what a later re-processing
// reads back from the folder give the same sums, captures and derived files.
TEST(FrameSums, LiveAndReadBackGiveTheSameSumsCapturesAndDerivedData) {
  files::StorageBudget budget;
  SessionStore store(testing::fresh_directory("frame-sums-store"), &budget);
  StandardPlanOptions options;
  options.frames_per_camera = 2;
  const SessionPlan plan = standard_plan(options);
  auto created = store.create(plan, "", nlohmann::json::array());
  const CaptureSources sources =
      resolve_capture_sources((testing::kSessionFormatOneSample / "results" / "led_library.json").string(), "builtin:nikon_d5100", 0.99);

  SessionFrameSums live;
  SessionCaptureBuilder live_builder(plan, sources);
  std::uint64_t index = 0;
  std::uint32_t seed = 12345;
  for (std::size_t s = 0; s < plan.steps.size(); ++s) {
    const Step& step = plan.steps[s];
    for (std::uint32_t f = 0; f < step.frames_per_camera; ++f)
      for (const char* camera : {"cam0", "cam1"}) {
        FrameRecord record;
        record.index = index;
        record.step = step.name;
        record.step_index = static_cast<int>(s);
        record.role = step.role;
        record.frame_in_step = f;
        record.exposure_us = step.exposure_us;
        FrameLedState led;
        if (step.role != StepRole::kDark) led.drive = {0.9, 0, 0, 0.1 * (s + 1), 0.2, 0.3 + 0.01 * f};
        record.led = led;
        record.camera = camera;
        record.sequence = index;
        record.width = 16, record.height = 12;
        record.pixel_format = drivers::PixelFormat::kBayerRG12;
        record.file = "frames/" + step.name + "/" + camera + "-" + std::to_string(index) + ".tiff";
        std::vector<std::uint8_t> samples(record.width * record.height * 2);
        const std::uint16_t base = step.role == StepRole::kDark ? 64 : step.role == StepRole::kWhite ? 3000 : 1500;
        for (std::size_t i = 0; i < samples.size() / 2; ++i) {
          seed = seed * 1664525u + 1013904223u;
          const auto value = static_cast<std::uint16_t>(base + (seed >> 24));
          std::memcpy(&samples[2 * i], &value, 2);
        }
        // As the pipeline's storage thread does: TIFF, journal, then the sums.
        fs::create_directories((created.folder / record.file).parent_path());
        write_frame_tiff(created.folder / record.file, record, samples, &budget);
        created.journal->append(to_json(record));
        live.add(record, samples);
        live_builder.add_frame(record, samples);
        ++index;
      }
  }
  ASSERT_TRUE(live_builder.complete());
  EXPECT_EQ(live_builder.camera(), "cam0");

  SessionFrameSums from_disk;
  EXPECT_EQ(add_stored_frames(from_disk, created.folder), index);
  EXPECT_EQ(add_stored_frames(from_disk, created.folder), 0u);  // nothing twice
  ASSERT_EQ(from_disk.by_step_and_camera().size(), live.by_step_and_camera().size());
  for (const auto& [key, sums] : live.by_step_and_camera()) {
    const FrameSums* read = from_disk.find(key.first, key.second);
    ASSERT_NE(read, nullptr) << key.first << " " << key.second;
    EXPECT_EQ(read->frames(), 2u);
    EXPECT_EQ(read->sums(), sums.sums()) << key.first << " " << key.second;
  }

  const Captures live_captures = live_builder.captures();
  const Captures read_captures = read_session_captures(created.folder, sources);
  EXPECT_EQ(read_captures.dark.width, 8);
  ASSERT_EQ(live_captures.captures.size(), 3u);
  ASSERT_EQ(read_captures.captures.size(), 3u);
  std::vector<std::pair<const IlluminatedCapture*, const IlluminatedCapture*>> pairs;
  for (std::size_t k = 0; k < 3; ++k) pairs.emplace_back(&live_captures.captures[k], &read_captures.captures[k]);
  for (int c = 0; c < 3; ++c) EXPECT_EQ(live_captures.dark.planes[c], read_captures.dark.planes[c]);
  for (const auto& [a, b] : pairs) {
    for (int c = 0; c < 3; ++c) {
      EXPECT_EQ(a->white.planes[c], b->white.planes[c]) << a->name;
      EXPECT_EQ(a->subject.planes[c], b->subject.planes[c]) << a->name;
    }
    EXPECT_TRUE((a->illuminant.values() == b->illuminant.values()).all()) << a->name;
  }
  // The binned mean: R of the first cell is the mean of sample (0, 0) over the two frames.
  const FrameSums* dark = live.find("dark", "cam0");
  EXPECT_EQ(live_captures.dark.planes[0][0], static_cast<float>(dark->sums()[0] / (2 * 4095.0)));
  EXPECT_EQ(live_captures.dark.planes[1][0],
            static_cast<float>(0.5 * (dark->sums()[1] / (2 * 4095.0) + dark->sums()[16] / (2 * 4095.0))));

  // Derived data from each, byte-identical content.
  write_derived_data(created.folder, plan, live, 0.99, *created.journal, &budget);
  fs::rename(created.folder / "derived", created.folder / "derived-live");
  write_derived_data(created.folder, read_session_plan(created.folder), from_disk, 0.99, *created.journal, &budget);
  int files_compared = 0;
  for (const auto& entry : fs::directory_iterator(created.folder / "derived-live")) {
    const auto a = files::read_exr(entry.path());
    const auto b = files::read_exr(created.folder / "derived" / entry.path().filename());
    ASSERT_EQ(a.channel_names, b.channel_names) << entry.path();
    for (std::size_t c = 0; c < a.channels.size(); ++c) {
      ASSERT_EQ(a.channels[c].size(), b.channels[c].size());
      EXPECT_EQ(std::memcmp(a.channels[c].data(), b.channels[c].data(), a.channels[c].size() * sizeof(float)), 0)
          << entry.path();
    }
    ++files_compared;
  }
  EXPECT_EQ(files_compared, 7 * 2 + 3 * 2);  // a mean per step and camera, an albedo per mix and camera
  // A mean file holds the mosaic in units of full scale.
  const auto dark_mean = files::read_exr(created.folder / "derived" / "dark-cam1-mean.exr");
  EXPECT_EQ(dark_mean.width, 16);
  EXPECT_EQ(dark_mean.channel("Y")[5], static_cast<float>(live.find("dark", "cam1")->sums()[5] / (2 * 4095.0)));
}

}  // namespace
}  // namespace chromo::session
