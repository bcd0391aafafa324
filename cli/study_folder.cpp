// A study's output folder (study_folder.hpp).
#include "study_folder.hpp"

#include <unistd.h>

#include <stdexcept>

#include "chromo/files/bounded_read.hpp"
#include "chromo/files/durable_file.hpp"
#include "study_inputs.hpp"

namespace chromo::cli::study {

namespace fs = std::filesystem;

const ManifestSession* Study::find(const std::string& name) const {
  for (const auto& session : sessions)
    if (session.name == name) return &session;
  return nullptr;
}

void check_output_folder(const fs::path& dir) {
  std::error_code error;
  if (!fs::exists(dir, error)) return;
  if (!fs::is_directory(dir, error))
    throw std::invalid_argument("--out " + dir.string() + ": exists and is not a directory");
  if (fs::exists(dir / "study.json", error)) return;
  // Empty but for a hold file (`chromo study hold` before the first run).
  bool only_hold = true;
  for (const auto& entry : fs::directory_iterator(dir, error)) only_hold = only_hold && entry.path().filename() == "hold";
  if (!only_hold)
    throw std::invalid_argument("--out " + dir.string() +
                                ": not empty and not a study folder (no study.json); give a new or empty folder");
}

void write_json_durably(const fs::path& file, const nlohmann::ordered_json& json) {
  fs::create_directories(file.parent_path());
  files::write_file_durably(file, json.dump(2) + "\n", nullptr);
}

void write_study(const Study& study) {
  nlohmann::ordered_json sessions = nlohmann::ordered_json::array();
  for (const auto& session : study.sessions) sessions.push_back({{"name", session.name}, {"folder", session.folder}});
  write_json_durably(study.dir / "study.json", {{"format", kStudyFormat},
                                                {"sessions", sessions},
                                                {"options", options_json(study.options, study.regions)}});
}

Study read_study(const fs::path& dir) {
  const fs::path file = dir / "study.json";
  std::error_code error;
  if (!fs::exists(file, error))
    throw std::invalid_argument(dir.string() + ": not a study folder (no study.json; `chromo study run` makes one)");
  Study study;
  study.dir = fs::absolute(dir).lexically_normal();
  try {
    const auto json = nlohmann::json::parse(files::read_text_file(file, "study"));
    if (json.at("format").get<std::string>() != kStudyFormat)
      throw std::invalid_argument("format: \"" + json.at("format").get<std::string>() + "\" (this chromo reads " +
                                  kStudyFormat + ")");
    for (const auto& session : json.at("sessions"))
      study.sessions.push_back({session.at("name").get<std::string>(), session.at("folder").get<std::string>()});
    study.options = options_from_json(json.at("options"));
    if (json.at("options").contains("regions"))
      study.regions = parse_regions(json.at("options").at("regions").get<std::vector<std::string>>());
  } catch (const nlohmann::json::exception& e) {
    throw std::invalid_argument(file.string() + ": " + e.what());
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(file.string() + ": " + e.what());
  }
  return study;
}

fs::path session_maps_dir(const fs::path& dir, const std::string& name) { return dir / "sessions" / name; }
fs::path record_file(const fs::path& dir, const std::string& name) { return dir / "records" / (name + ".json"); }

std::optional<nlohmann::ordered_json> read_record(const fs::path& dir, const std::string& name) {
  const fs::path file = record_file(dir, name);
  std::error_code error;
  if (!fs::exists(file, error)) return std::nullopt;
  try {
    return nlohmann::ordered_json::parse(files::read_text_file(file, "study record"));
  } catch (const std::exception&) {
    return std::nullopt;  // a damaged record: the session is estimated again
  }
}

std::string host_name() {
  char name[256] = {};
  if (::gethostname(name, sizeof name - 1) != 0) return "host";
  std::string host(name);
  if (auto dot = host.find('.'); dot != std::string::npos) host.resize(dot);
  return host.empty() ? "host" : host;
}

fs::path hold_file(const fs::path& dir) { return dir / "hold"; }

}  // namespace chromo::cli::study
