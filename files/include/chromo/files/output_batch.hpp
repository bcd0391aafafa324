#pragma once
// Crash-safe writing of a command's set of output files.
//
// Each file is written to its temporary (temporary_file.hpp:
// DIR/.tmp-<pid>-<tid>-NAME, the extension stays last, so OpenCV and OpenEXR
// pick the format by name), and commit() fsyncs every
// temporary, renames them all into place and fsyncs the directory. If the
// batch is destroyed before commit() (an exception on the way), the
// temporaries are removed, and so is DIR if the batch created it: a failed
// command leaves nothing behind. Files committed earlier are never touched.
// Not thread-safe: one batch per command run.

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace chromo::files {

class OutputBatch {
 public:
  // Creates the directory if needed; std::runtime_error if it exists as a file
  // or cannot be created.
  explicit OutputBatch(std::filesystem::path directory);
  ~OutputBatch();
  OutputBatch(const OutputBatch&) = delete;
  OutputBatch& operator=(const OutputBatch&) = delete;

  // Where to write `name` now; it becomes DIR/name at commit().
  std::filesystem::path temporary(const std::string& name);
  // Writes text (JSON) to the temporary of `name`.
  void write_text(const std::string& name, const std::string& text);
  // fsync + rename every pending file; returns the final paths.
  std::vector<std::filesystem::path> commit();
  const std::filesystem::path& directory() const { return directory_; }

 private:
  std::filesystem::path directory_;
  bool created_directory_ = false;
  std::vector<std::pair<std::filesystem::path, std::filesystem::path>> pending_;  // temporary → final
};

}  // namespace chromo::files
