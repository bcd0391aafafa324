// The one temporary-name rule and the cleaner of a crash's leftovers.
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>

#include <gtest/gtest.h>

#include "chromo/files/durable_file.hpp"
#include "chromo/files/output_batch.hpp"
#include "chromo/files/temporary_file.hpp"
#include "../support/fresh_directory.hpp"

namespace chromo::files {
namespace {

namespace fs = std::filesystem;
using testing::fresh_directory;

void touch(const fs::path& path) { std::ofstream(path) << "x"; }

// The pid of a process that has exited (and been reaped): no process runs under it.
long exited_pid() {
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  int status = 0;
  ::waitpid(child, &status, 0);
  return child;
}

std::string leftover_name(long pid, const std::string& name) {
  return ".tmp-" + std::to_string(pid) + "-" + std::to_string(pid) + "-" + name;
}

TEST(TemporaryFile, NameKeepsDirectoryAndExtensionAndFollowsTheRule) {
  const fs::path temporary = temporary_path_for("/some/dir/cm.exr");
  EXPECT_EQ(temporary.parent_path(), fs::path("/some/dir"));
  EXPECT_EQ(temporary.extension(), ".exr");
  EXPECT_EQ(temporary.filename().string().rfind(".tmp-" + std::to_string(::getpid()) + "-", 0), 0u) << temporary;
  EXPECT_EQ(temporary_writer_pid(temporary.filename().string()), ::getpid());
}

TEST(TemporaryFile, OnlyNamesOfTheRuleAreTemporaries) {
  EXPECT_EQ(temporary_writer_pid(".tmp-12-34-frame.tiff"), 12);
  EXPECT_FALSE(temporary_writer_pid("frame.tiff"));
  EXPECT_FALSE(temporary_writer_pid("profiles.f32.tmp"));
  EXPECT_FALSE(temporary_writer_pid("frame.tiff.tmp-12"));  // an older rule's name
  EXPECT_FALSE(temporary_writer_pid(".tmp-12-34-"));        // no final name
  EXPECT_FALSE(temporary_writer_pid(".tmp-x-34-a"));
  EXPECT_FALSE(temporary_writer_pid(".tmp-12-a"));
}

TEST(TemporaryFile, EveryWriterUsesTheRule) {
  auto dir = fresh_directory("temporary_rule");
  OutputBatch batch(dir);
  EXPECT_EQ(batch.temporary("cm.png"), temporary_path_for(dir / "cm.png"));
  fs::path seen;
  commit_file_durably(dir / "a.bin", nullptr, [&](const fs::path& temporary) {
    seen = temporary;
    touch(temporary);
  });
  EXPECT_EQ(seen, temporary_path_for(dir / "a.bin"));
  fs::remove_all(dir);
}

TEST(TemporaryFile, CleanerRemovesACrashedWritersLeftoversAndLeavesOtherFiles) {
  auto dir = fresh_directory("leftovers");
  fs::create_directories(dir / "frames");
  const long crashed = exited_pid();
  touch(dir / leftover_name(crashed, "session.json"));
  touch(dir / "frames" / leftover_name(crashed, "frame_0001.tiff"));
  touch(dir / "session.json");
  touch(dir / "profiles.f32.tmp");
  touch(dir / "frame.tiff.tmp-12");
  touch(dir / ".tmp-notes");

  EXPECT_EQ(remove_leftover_temporaries(dir), 1u);  // this folder only
  EXPECT_FALSE(fs::exists(dir / leftover_name(crashed, "session.json")));
  EXPECT_TRUE(fs::exists(dir / "frames" / leftover_name(crashed, "frame_0001.tiff")));
  EXPECT_EQ(remove_leftover_temporaries(dir, Subfolders::kInclude), 1u);
  EXPECT_FALSE(fs::exists(dir / "frames" / leftover_name(crashed, "frame_0001.tiff")));
  for (const char* kept : {"session.json", "profiles.f32.tmp", "frame.tiff.tmp-12", ".tmp-notes"})
    EXPECT_TRUE(fs::exists(dir / kept)) << kept;
  fs::remove_all(dir);
}

TEST(TemporaryFile, CleanerLeavesTheTemporaryOfAnotherRunningProcess) {
  auto dir = fresh_directory("live_writer");
  int pipe_fds[2];
  ASSERT_EQ(::pipe(pipe_fds), 0);
  const pid_t writer = ::fork();
  if (writer == 0) {  // a writer that runs until the test closes the pipe
    ::close(pipe_fds[1]);
    char byte;
    (void)!::read(pipe_fds[0], &byte, 1);
    ::_exit(0);
  }
  ::close(pipe_fds[0]);
  touch(dir / leftover_name(writer, "cache.bin"));
  touch(dir / leftover_name(::getpid(), "mine.json"));  // the caller's own: not being written (the contract)
  EXPECT_EQ(remove_leftover_temporaries(dir), 1u);
  EXPECT_TRUE(fs::exists(dir / leftover_name(writer, "cache.bin")));
  EXPECT_FALSE(fs::exists(dir / leftover_name(::getpid(), "mine.json")));
  ::close(pipe_fds[1]);
  int status = 0;
  ::waitpid(writer, &status, 0);
  EXPECT_EQ(remove_leftover_temporaries(dir), 1u);  // its writer has gone
  EXPECT_TRUE(fs::is_empty(dir));
  fs::remove_all(dir);
}

TEST(TemporaryFile, CleanerOfAMissingDirectoryRemovesNothing) {
  EXPECT_EQ(remove_leftover_temporaries(fresh_directory("missing") / "absent"), 0u);
}

}  // namespace
}  // namespace chromo::files
