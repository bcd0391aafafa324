// TableCacheReferences: the table-cache entries each session's results name,
// read once per results (daemon/src/operations/table_cache_references.cpp).
#include "chromo/daemon/internal/operations/table_cache_references.hpp"

#include <fstream>

#include <gtest/gtest.h>
#include <unistd.h>

namespace chromo::daemon {
namespace {

namespace fs = std::filesystem;

void write_summary(const fs::path& file, const std::string& text) {
  fs::create_directories(file.parent_path());
  std::ofstream(file) << text;
}

std::string table(const std::string& forward, const std::string& inverse) {
  return R"({"table": {"key": ")" + forward + R"(", "inverse_key": ")" + inverse + R"("}})";
}

TEST(TableCacheReferences, EntriesOnlyASessionNamesAreReadOnceAndAgainOnlyWhenItsResultsChange) {
  const fs::path root = fs::temp_directory_path() / ("chromo_table_refs_" + std::to_string(::getpid()));
  fs::remove_all(root);
  const std::string aa = "00000000000000aa", bb = "00000000000000bb", cc = "00000000000000cc";
  // a: one camera, aa/cc; b: several cameras (index without a table), bb/cc
  // in its camera's summary; c: no results; d: results that are no JSON.
  write_summary(root / "a" / "results" / "summary.json", table(aa, cc));
  write_summary(root / "b" / "results" / "summary.json", R"({"cameras": [{"name": "cam0", "folder": "cam0"}]})");
  write_summary(root / "b" / "results" / "cam0" / "summary.json", table(bb, cc));
  fs::create_directories(root / "c");
  write_summary(root / "d" / "results" / "summary.json", "not json");

  TableCacheReferences references;
  EXPECT_EQ(references.named_only_by(root, root / "a"),
            (std::set<std::string>{"forward_table_" + aa + ".bin"}));  // cc is b's too
  const int first = references.summaries_read();
  EXPECT_EQ(first, 4);  // a, b's index and camera, d
  EXPECT_EQ(references.named_only_by(root, root / "b"), (std::set<std::string>{"forward_table_" + bb + ".bin"}));
  EXPECT_EQ(references.summaries_read(), first);  // nothing changed: nothing parsed again

  // a re-estimated (other results): read again, alone.
  write_summary(root / "a" / "results" / "summary.json",
                R"({"table": {"key": ")" + aa + R"(", "inverse_key": "00000000000000dd"}, "estimated": 2})");
  EXPECT_EQ(references.named_only_by(root, root / "b"),
            (std::set<std::string>{"forward_table_" + bb + ".bin", "inverse_table_" + cc + ".bin"}));
  EXPECT_EQ(references.summaries_read(), first + 1);

  // a deleted: forgotten, and no longer names anything.
  fs::remove_all(root / "a");
  references.forget(root / "a");
  EXPECT_TRUE(references.entries_of(root / "a").empty());
  fs::remove_all(root);
}

}  // namespace
}  // namespace chromo::daemon
