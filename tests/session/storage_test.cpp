// The session folder's storage: the journal (torn tails, a full budget), raw
// frames as TIFF at native bit depth, derived data as OpenEXR.
#include <sys/stat.h>

#include <algorithm>
#include <fstream>

#include <ImfInputFile.h>
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <gtest/gtest.h>

#include "chromo/files/bounded_read.hpp"
#include "chromo/session/frame_files.hpp"
#include "chromo/session/journal.hpp"
#include "chromo/session/session_read_cache.hpp"
#include "chromo/session/session_store.hpp"
#include "../support/fresh_directory.hpp"
#include "../support/one_step_plan.hpp"

namespace chromo::session {
namespace {

using testing::fresh_directory;

// Issue 40, row 12: sessions were listed by the id inside session.json but
// fetched by folder name: a copy merged into the original in the list, and
// an id of "../../etc" was listed. Such folders are skipped, with the reason.
TEST(SessionStore, RecoverSkipsAFolderWhoseIdIsNotItsNameAndSaysWhy) {
  const auto root = fresh_directory("store-ids");
  const SessionPlan plan = testing::one_dark_step_plan();
  std::string id;
  {
    SessionStore store(root, nullptr);
    id = store.create(plan, "subject", nlohmann::json::object()).id;
  }
  std::filesystem::copy(root / id, root / "copy-of-it", std::filesystem::copy_options::recursive);
  std::filesystem::copy(root / id, root / "edited", std::filesystem::copy_options::recursive);
  auto json = nlohmann::json::parse(std::ifstream(root / "edited" / "session.json"));
  json["id"] = "../../etc";
  std::ofstream(root / "edited" / "session.json") << json.dump();

  SessionStore store(root, nullptr);
  std::vector<std::string> skipped;
  const auto sessions = store.recover(&skipped);
  ASSERT_EQ(sessions.size(), 1u);
  EXPECT_EQ(sessions[0].record.id, id);
  ASSERT_EQ(skipped.size(), 2u);
  std::sort(skipped.begin(), skipped.end());
  EXPECT_NE(skipped[0].find("copy-of-it: session.json names the id \"" + id + "\", not the folder's name"), std::string::npos)
      << skipped[0];
  EXPECT_NE(skipped[1].find("edited: session.json names the id \"../../etc\""), std::string::npos) << skipped[1];
  std::filesystem::remove_all(root);
}

TEST(Journal, RecordsSurviveAndATornTailIsIgnoredThenClosed) {
  auto dir = fresh_directory("journal");
  {
    Journal journal(dir / "j.jsonl", nullptr);
    journal.append({{"type", "a"}, {"n", 1}});
    journal.append({{"type", "b"}, {"n", 2}});
  }
  {  // A crash in the middle of an append.
    std::ofstream out(dir / "j.jsonl", std::ios::app);
    out << "{\"type\":\"c\",\"n\":";
  }
  auto contents = read_journal(dir / "j.jsonl");
  ASSERT_EQ(contents.records.size(), 2u);
  EXPECT_TRUE(contents.torn_tail);
  EXPECT_EQ(contents.records[1]["n"], 2);
  EXPECT_TRUE(contents.records[0].contains("t"));
  {  // Reopening closes the torn line so the next record stays intact.
    Journal journal(dir / "j.jsonl", nullptr);
    journal.append({{"type", "d"}});
  }
  contents = read_journal(dir / "j.jsonl");
  ASSERT_EQ(contents.records.size(), 3u);
  EXPECT_EQ(contents.records[2]["type"], "d");
  EXPECT_EQ(contents.malformed_lines, 1);
  EXPECT_FALSE(contents.torn_tail);
  std::filesystem::remove_all(dir);
}

// Issue 40, row 11: GetSession re-read a long session's whole journal on
// every call. The cache reads a folder once while its files are unchanged,
// and again after any append.
TEST(SessionReadCache, ReadsAnUnchangedSessionOnceAndAnAppendedOneAgain) {
  const auto root = fresh_directory("read-cache");
  SessionStore store(root, nullptr);
  auto created = store.create(testing::one_dark_step_plan(), "subject", nlohmann::json::object());
  const auto folder = root / created.id;
  SessionReadCache cache(2);
  const auto read = [&store](const std::filesystem::path& f) { return store.read_session(f); };
  EXPECT_EQ(cache.get(folder, read).record.state, OperationState::kPending);
  EXPECT_EQ(cache.get(folder, read).record.state, OperationState::kPending);
  EXPECT_EQ(cache.reads(), 1u);
  created.journal->append({{"type", "state"}, {"state", "succeeded"}});
  EXPECT_EQ(cache.get(folder, read).record.state, OperationState::kSucceeded);
  EXPECT_EQ(cache.reads(), 2u);
  // A journal that is not a regular file is refused naming it, and nothing is kept.
  created.journal.reset();
  std::filesystem::remove(folder / "journal.jsonl");
  ASSERT_EQ(::mkfifo((folder / "journal.jsonl").c_str(), 0600), 0);
  try {
    cache.get(folder, read);
    ADD_FAILURE() << "a FIFO journal was read";
  } catch (const files::InputFileError& error) {
    EXPECT_NE(std::string(error.what()).find("journal.jsonl"), std::string::npos) << error.what();
  }
  EXPECT_THROW(cache.get(folder, read), files::InputFileError);
  EXPECT_EQ(cache.reads(), 4u);
  std::filesystem::remove_all(root);
}

TEST(Journal, FullBudgetRefusesTheRecordAndWritesNothing) {
  auto dir = fresh_directory("journal-full");
  files::StorageBudget budget(80);
  Journal journal(dir / "j.jsonl", &budget);
  journal.append({{"type", "a"}});
  EXPECT_THROW(journal.append({{"type", std::string(100, 'x')}}), files::StorageFullError);
  auto contents = read_journal(dir / "j.jsonl");
  EXPECT_EQ(contents.records.size(), 1u);
  EXPECT_FALSE(contents.torn_tail);
  std::filesystem::remove_all(dir);
}

struct RampFrame {
  FrameRecord record;
  std::vector<std::uint8_t> samples;
};
RampFrame ramp_frame(drivers::PixelFormat format, int width, int height) {
  RampFrame frame;
  frame.record.step = "x";
  frame.record.camera = "cam0";
  frame.record.width = width;
  frame.record.height = height;
  frame.record.pixel_format = format;
  frame.samples.resize(drivers::pixel_format_info(format).frame_bytes(width, height));
  for (std::size_t i = 0; i < frame.samples.size(); ++i) frame.samples[i] = static_cast<std::uint8_t>(i * 7 + 3);
  return frame;
}

TEST(ImageFiles, TiffKeepsNativeBitDepthAndEveryByte) {
  auto dir = fresh_directory("tiff");
  for (auto [format, bits, samples] : {std::tuple{drivers::PixelFormat::kMono8, 8, 1},
                                       std::tuple{drivers::PixelFormat::kBayerRG12, 16, 1},
                                       std::tuple{drivers::PixelFormat::kMono16, 16, 1},
                                       std::tuple{drivers::PixelFormat::kRgb8, 8, 3}}) {
    auto frame = ramp_frame(format, 37, 11);
    const std::string name(drivers::pixel_format_name(format));
    auto path = dir / (name + ".tiff");
    write_frame_tiff(path, frame.record, frame.samples, nullptr);
    auto image = read_tiff(path);
    EXPECT_EQ(image.width, 37);
    EXPECT_EQ(image.height, 11);
    EXPECT_EQ(image.bits_per_sample, bits);
    EXPECT_EQ(image.samples_per_pixel, samples);
    EXPECT_EQ(image.data, frame.samples) << name;
    // The description is the frame's journal record.
    EXPECT_EQ(frame_record_from_json(nlohmann::json::parse(image.description)), frame.record) << name;
  }
  auto bad = ramp_frame(drivers::PixelFormat::kMono8, 4, 4);
  bad.samples.pop_back();
  EXPECT_THROW(write_frame_tiff(dir / "bad.tiff", bad.record, bad.samples, nullptr), std::invalid_argument);
  EXPECT_FALSE(std::filesystem::exists(dir / "bad.tiff"));
  std::filesystem::remove_all(dir);
}

TEST(ImageFiles, ExrHoldsFloatChannels) {
  auto dir = fresh_directory("exr");
  std::vector<float> values{0.f, 0.25f, 0.5f, 1.5f, -1.f, 1e-3f};
  write_float_exr(dir / "a.exr", 3, 2, {{"Y", values}}, nullptr);
  Imf::InputFile file((dir / "a.exr").c_str());
  EXPECT_NE(file.header().channels().findChannel("Y"), nullptr);
  std::vector<float> read(6);
  Imf::FrameBuffer buffer;
  buffer.insert("Y", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(read.data()), sizeof(float), 3 * sizeof(float)));
  file.setFrameBuffer(buffer);
  file.readPixels(0, 1);
  EXPECT_EQ(read, values);
  EXPECT_THROW(write_float_exr(dir / "b.exr", 3, 3, {{"Y", values}}, nullptr), std::invalid_argument);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace chromo::session
