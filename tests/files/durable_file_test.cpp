// Durable files and the storage budget that stands in for a full disk.
#include <fstream>

#include <gtest/gtest.h>

#include "chromo/files/durable_file.hpp"
#include "chromo/files/temporary_file.hpp"
#include "../support/fresh_directory.hpp"

namespace chromo::files {
namespace {

using testing::fresh_directory;

TEST(DurableFile, WritesAndReplacesWithoutLeavingTemporaries) {
  auto dir = fresh_directory("durable");
  write_file_durably(dir / "a.json", std::string("first"), nullptr);
  write_file_durably(dir / "a.json", std::string("second"), nullptr);
  std::ifstream in(dir / "a.json");
  std::string text;
  std::getline(in, text);
  EXPECT_EQ(text, "second");
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), std::filesystem::directory_iterator()), 1);
  std::filesystem::remove_all(dir);
}

TEST(DurableFile, BudgetExhaustedLeavesTargetUntouchedAndNoTemporary) {
  auto dir = fresh_directory("budget");
  StorageBudget budget(10);
  write_file_durably(dir / "small", std::string("12345"), &budget);
  EXPECT_THROW(write_file_durably(dir / "big", std::string("1234567890"), &budget), StorageFullError);
  EXPECT_FALSE(std::filesystem::exists(dir / "big"));
  EXPECT_FALSE(std::filesystem::exists(temporary_path_for(dir / "big")));
  EXPECT_EQ(budget.used_bytes(), 5u);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace chromo::files
