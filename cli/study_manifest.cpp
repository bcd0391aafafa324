// A study's manifest: a listing file or a glob (study_manifest.hpp).
#include "study_manifest.hpp"

#include <glob.h>

#include <algorithm>
#include <map>
#include <stdexcept>

#include "chromo/files/bounded_read.hpp"

namespace chromo::cli::study {

namespace fs = std::filesystem;

bool usable_session_name(const std::string& name) {
  if (name.empty() || name.size() > 100 || name == "." || name == "..") return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '.' ||
           c == '+' || c == '-';
  });
}

namespace {

bool is_glob(const std::string& text) { return text.find_first_of("*?[") != std::string::npos; }

std::string trim(const std::string& line) {
  const auto first = line.find_first_not_of(" \t\r");
  if (first == std::string::npos) return "";
  return line.substr(first, line.find_last_not_of(" \t\r") - first + 1);
}

// Adds one session; `where` says where it came from ("MANIFEST:LINE" or the glob).
void add_session(std::vector<ManifestSession>& sessions, std::map<std::string, std::string>& seen,
                 const fs::path& folder, const std::string& where) {
  std::error_code error;
  if (!fs::is_directory(folder, error))
    throw std::invalid_argument(where + ": \"" + folder.string() + "\" is not a session folder (" +
                                (fs::exists(folder, error) ? "not a directory" : "no such directory") + ")");
  const fs::path absolute = fs::absolute(folder).lexically_normal();
  std::string name = (absolute / "x").parent_path().filename().string();
  if (name.empty()) name = absolute.parent_path().filename().string();
  if (!usable_session_name(name))
    throw std::invalid_argument(where + ": the session folder's name \"" + name +
                                "\" cannot name its maps (1-100 of A-Z a-z 0-9 _ . + -)");
  if (auto found = seen.find(name); found != seen.end())
    throw std::invalid_argument(where + ": a second session named \"" + name + "\" (the first at " + found->second +
                                "); sessions are known by their folder's name, which must be unique in a study");
  seen[name] = where;
  sessions.push_back({name, (absolute / "x").parent_path()});
}

}  // namespace

std::vector<ManifestSession> read_manifest(const std::string& manifest) {
  std::vector<ManifestSession> sessions;
  std::map<std::string, std::string> seen;  // name → where
  std::error_code error;
  if (fs::is_regular_file(manifest, error)) {
    const std::string text = files::read_text_file(manifest, "study manifest");
    const fs::path base = fs::absolute(manifest).parent_path();
    std::size_t line_number = 0, start = 0;
    while (start <= text.size()) {
      const auto end = std::min(text.find('\n', start), text.size());
      const std::string line = trim(text.substr(start, end - start));
      ++line_number;
      start = end + 1;
      if (line.empty() || line[0] == '#') continue;
      const fs::path path(line);
      add_session(sessions, seen, path.is_absolute() ? path : base / path,
                  manifest + ":" + std::to_string(line_number));
    }
    if (sessions.empty()) throw std::invalid_argument(manifest + ": the manifest lists no session folder");
    return sessions;
  }
  if (fs::exists(manifest, error))
    throw std::invalid_argument(manifest + ": the manifest is neither a regular file nor a glob");
  if (!is_glob(manifest))
    throw std::invalid_argument(manifest + ": no such manifest file (and not a glob: no *, ? or [)");
  glob_t matches{};
  const int status = ::glob(manifest.c_str(), GLOB_ONLYDIR | GLOB_MARK, nullptr, &matches);
  std::vector<std::string> paths;
  for (std::size_t i = 0; status == 0 && i < matches.gl_pathc; ++i) paths.emplace_back(matches.gl_pathv[i]);
  ::globfree(&matches);
  std::erase_if(paths, [](const std::string& p) { return !fs::is_directory(p); });
  if (paths.empty()) throw std::invalid_argument(manifest + ": the glob matches no session folder");
  for (const std::string& path : paths) add_session(sessions, seen, path, "glob " + manifest);
  return sessions;
}

}  // namespace chromo::cli::study
