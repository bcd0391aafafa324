// A study session's inputs hash (study_inputs.hpp).
#include "study_inputs.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <fstream>
#include <stdexcept>
#include <vector>

#include "chromo/estimation/forward_table.hpp"
#include "chromo/estimation/measurement.hpp"
#include "chromo/files/fnv1a.hpp"
#include "chromo/maps/estimator_version.hpp"
#include "chromo/spectral/camera.hpp"
#include "chromo/spectral/cie.hpp"

#include "chromo/estimation/model_discrepancy.hpp"

namespace chromo::cli::study {

namespace fs = std::filesystem;

nlohmann::ordered_json options_json(const EstimateOptions& options, const std::vector<RegionSpec>& regions) {
  nlohmann::ordered_json json{{"method", options.method},
                              {"model", options.model},
                              {"discrepancy", options.discrepancy},
                              {"neighbourhood_flags", options.neighbourhood_flags},
                              {"order_pooling", options.order_pooling},
                              {"led_library", options.led_library.empty() ? "" : fs::absolute(options.led_library).string()},
                              {"camera", options.camera},
                              {"camera_of", options.camera_of},
                              {"white_reflectance", options.white_reflectance}};
  if (!regions.empty()) json["regions"] = region_options(regions);
  return json;
}

EstimateOptions options_from_json(const nlohmann::json& json) {
  EstimateOptions options;
  try {
    options.method = json.at("method").get<std::string>();
    options.model = json.at("model").get<std::string>();
    options.discrepancy = json.value("discrepancy", std::string("learned"));
    options.neighbourhood_flags = json.at("neighbourhood_flags").get<bool>();
    options.order_pooling = json.at("order_pooling").get<bool>();
    options.led_library = json.at("led_library").get<std::string>();
    options.camera = json.at("camera").get<std::string>();
    options.camera_of = json.at("camera_of").get<std::vector<std::string>>();
    options.white_reflectance = json.at("white_reflectance").get<double>();
  } catch (const nlohmann::json::exception& e) {
    throw std::invalid_argument(std::string("options: ") + e.what());
  }
  return options;
}

std::string estimator_version() { return maps::estimator_version(); }

namespace {

void add_text(files::Fnv1a& hash, const std::string& text) {
  const std::uint64_t size = text.size();
  hash.add(size);
  hash.add(text.data(), text.size());
}

// The file's name (as given) and bytes.
void add_file(files::Fnv1a& hash, const fs::path& file, const std::string& name) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw std::runtime_error(file.string() + ": cannot be read for the study's input hash");
  add_text(hash, name);
  std::vector<char> buffer(1 << 20);
  std::uint64_t size = 0;
  while (in.read(buffer.data(), static_cast<std::streamsize>(buffer.size())) || in.gcount() > 0) {
    hash.add(buffer.data(), static_cast<std::size_t>(in.gcount()));
    size += static_cast<std::uint64_t>(in.gcount());
  }
  if (in.bad()) throw std::runtime_error(file.string() + ": read error for the study's input hash");
  hash.add(size);
}

bool is_session_input(const std::string& relative) {
  if (relative == "session.json" || relative == "journal.jsonl") return true;
  if (relative.rfind("frames/", 0) == 0) return true;
  return relative.rfind("results/led_library", 0) == 0 && relative.find('/', 8) == std::string::npos &&
         relative.size() > 5 && relative.substr(relative.size() - 5) == ".json";
}

// A sensitivity spec that names a file ("builtin:NAME" does not).
void add_spec_file(files::Fnv1a& hash, const std::string& spec, const std::string& label) {
  if (spec.empty() || spec.rfind("builtin:", 0) == 0) return;
  add_file(hash, spec, label);
}

}  // namespace

std::string input_hash(const fs::path& session_folder, const EstimateOptions& options, const std::string& version,
                       const std::vector<RegionSpec>& regions) {
  files::Fnv1a hash;
  add_text(hash, "chromosphere-study-inputs/1");
  add_text(hash, version);
  add_text(hash, options_json(options, regions).dump());
  // The learned model statistics: the shipped residual table they are learned from.
  if (options.discrepancy == "learned") add_text(hash, estimation::residuals_csv(estimation::nist_forearm_residuals(), ""));
  std::vector<std::string> inputs;
  std::error_code error;
  if (fs::is_directory(session_folder, error)) {
    for (auto it = fs::recursive_directory_iterator(session_folder, error); !error && it != fs::end(it);
         it.increment(error)) {
      if (!it->is_regular_file(error)) continue;
      const std::string relative = it->path().lexically_relative(session_folder).generic_string();
      if (is_session_input(relative)) inputs.push_back(relative);
    }
    if (error) throw std::runtime_error(session_folder.string() + ": cannot be listed: " + error.message());
  }
  std::sort(inputs.begin(), inputs.end());
  for (const std::string& relative : inputs) add_file(hash, session_folder / relative, relative);
  if (!options.led_library.empty()) add_file(hash, options.led_library, "--led-library");
  add_spec_file(hash, options.camera, "--camera");
  for (const std::string& entry : options.camera_of)
    if (auto equals = entry.find('='); equals != std::string::npos)
      add_spec_file(hash, entry.substr(equals + 1), "--camera-of " + entry.substr(0, equals));
  for (const RegionSpec& region : regions)
    for (const fs::path& file : region_input_files(session_folder, region))
      add_file(hash, file, "--region " + region.name + ": " + file.string());
  return fmt::format("{:016x}", hash.h);
}

}  // namespace chromo::cli::study
