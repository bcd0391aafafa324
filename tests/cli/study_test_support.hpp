#pragma once
// What the study tests share: stored sessions made for them, the study
// table read back, maps compared channel by channel.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "../support/fresh_directory.hpp"
#include "../support/rendered_session_folder.hpp"
#include "chromo/files/float_image.hpp"

namespace chromo::study_testing {

namespace fs = std::filesystem;

// Shared by the test processes (one per test): tables are written by rename.
inline fs::path table_cache() { return fs::temp_directory_path() / "chromo-test-forward-tables"; }

// `good` small rendered sessions s1..sN (s2 has two cameras) and one corrupt
// session "broken" (s1's folder with its W57 subject frame cut short).
inline std::vector<fs::path> make_study_sessions(const fs::path& root, int good) {
  std::vector<fs::path> folders;
  for (int i = 1; i <= good; ++i) {
    testing::RenderedSessionFolder spec;
    spec.name = "s" + std::to_string(i);
    spec.seed = 100 + i;
    spec.scene_size = 48;
    spec.cameras = i == 2 ? 2 : 1;
    spec.subject = "subject " + std::to_string(i);
    folders.push_back(testing::write_rendered_session_folder(root, spec));
  }
  const fs::path broken = root / "broken";
  fs::copy(folders[0], broken, fs::copy_options::recursive);
  for (const auto& entry : fs::recursive_directory_iterator(broken / "frames" / "subject_w57"))
    if (entry.is_regular_file()) fs::resize_file(entry.path(), 1000);
  folders.push_back(broken);
  return folders;
}

inline void write_manifest(const fs::path& file, const std::vector<fs::path>& folders) {
  std::ofstream out(file);
  out << "# a study's sessions\n";
  for (const auto& folder : folders) out << folder.string() << "\n";
}

// DIR/study.csv as rows of column → value.
inline std::vector<std::map<std::string, std::string>> read_table(const fs::path& csv) {
  std::ifstream in(csv);
  std::vector<std::map<std::string, std::string>> rows;
  auto split = [](const std::string& line) {
    std::vector<std::string> cells;
    std::string cell;
    bool quoted = false;
    for (std::size_t i = 0; i < line.size(); ++i) {
      const char c = line[i];
      if (quoted) {
        if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') cell += '"', ++i;
        else if (c == '"') quoted = false;
        else cell += c;
      } else if (c == '"') quoted = true;
      else if (c == ',') cells.push_back(cell), cell.clear();
      else cell += c;
    }
    cells.push_back(cell);
    return cells;
  };
  std::string line;
  std::getline(in, line);
  const auto header = split(line);
  while (std::getline(in, line)) {
    const auto cells = split(line);
    std::map<std::string, std::string> row;
    for (std::size_t i = 0; i < header.size() && i < cells.size(); ++i) row[header[i]] = cells[i];
    rows.push_back(row);
  }
  return rows;
}

inline nlohmann::json read_json(const fs::path& file) {
  std::ifstream in(file);
  return nlohmann::json::parse(in);
}

// Every channel of two maps.exr files, value for value.
inline void expect_identical_maps(const fs::path& a, const fs::path& b) {
  const files::FloatImage x = files::read_exr(a), y = files::read_exr(b);
  ASSERT_EQ(x.width, y.width) << a;
  ASSERT_EQ(x.height, y.height) << a;
  ASSERT_EQ(x.channel_names, y.channel_names) << a;
  for (std::size_t c = 0; c < x.channels.size(); ++c) {
    std::size_t differing = 0;
    for (std::size_t i = 0; i < x.channels[c].size(); ++i)
      if (std::memcmp(&x.channels[c][i], &y.channels[c][i], sizeof(float)) != 0) ++differing;
    EXPECT_EQ(differing, 0u) << a << " channel " << x.channel_names[c];
  }
}

// The maps.exr files under a session's maps folder (one camera: maps.exr; several: <camera>/maps.exr).
inline std::vector<fs::path> maps_files(const fs::path& dir) {
  std::vector<fs::path> out;
  for (const auto& entry : fs::recursive_directory_iterator(dir))
    if (entry.path().filename() == "maps.exr") out.push_back(entry.path().lexically_relative(dir));
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace chromo::study_testing
