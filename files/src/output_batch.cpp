#include "chromo/files/output_batch.hpp"

#include <fstream>
#include <stdexcept>

#include "chromo/files/durable_file.hpp"
#include "chromo/files/temporary_file.hpp"

namespace chromo::files {
namespace fs = std::filesystem;

OutputBatch::OutputBatch(fs::path directory) : directory_(std::move(directory)) {
  if (directory_.empty()) throw std::runtime_error("output directory: empty path");
  if (fs::exists(directory_) && !fs::is_directory(directory_))
    throw std::runtime_error(directory_.string() + ": exists and is not a directory");
  std::error_code ec;
  if (!fs::exists(directory_)) {
    created_directory_ = fs::create_directories(directory_, ec);
    if (ec) throw std::runtime_error(directory_.string() + ": cannot create (" + ec.message() + ")");
  }
}

OutputBatch::~OutputBatch() {
  std::error_code ec;
  for (const auto& [temporary, final_path] : pending_) fs::remove(temporary, ec);
  if (created_directory_ && fs::is_empty(directory_, ec)) fs::remove(directory_, ec);
}

fs::path OutputBatch::temporary(const std::string& name) {
  const fs::path final_path = directory_ / name, temporary = temporary_path_for(final_path);
  pending_.emplace_back(temporary, final_path);
  return temporary;
}

void OutputBatch::write_text(const std::string& name, const std::string& text) {
  const fs::path path = temporary(name);
  std::ofstream out(path, std::ios::binary);
  out << text;
  out.close();
  if (!out) throw std::runtime_error(path.string() + ": cannot write");
}

std::vector<fs::path> OutputBatch::commit() {
  for (const auto& [temporary, final_path] : pending_) fsync_file(temporary);
  std::vector<fs::path> written;
  for (const auto& [temporary, final_path] : pending_) fs::rename(temporary, final_path), written.push_back(final_path);
  pending_.clear();
  fsync_directory(directory_);
  return written;
}

}  // namespace chromo::files
