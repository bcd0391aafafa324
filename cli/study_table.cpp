// The study table (study_table.hpp).
#include "study_table.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "chromo/files/bounded_read.hpp"
#include "chromo/files/durable_file.hpp"
#include "chromo/files/float_image.hpp"

namespace chromo::cli::study {

namespace fs = std::filesystem;

double quantile_of_sorted(const std::vector<float>& sorted, double p) {
  if (sorted.empty()) return std::numeric_limits<double>::quiet_NaN();
  const double h = p * static_cast<double>(sorted.size() - 1);
  const auto low = static_cast<std::size_t>(std::floor(h));
  const std::size_t high = std::min(low + 1, sorted.size() - 1);
  return sorted[low] + (h - static_cast<double>(low)) * (static_cast<double>(sorted[high]) - sorted[low]);
}

namespace {

// Over the explained cells (inside the mask when one is given); *explained: their count.
nlohmann::ordered_json parameter_statistics(const files::FloatImage& image, const std::vector<std::uint8_t>* mask = nullptr,
                                            std::size_t* explained = nullptr) {
  const std::vector<float>& flags = image.channel("flags");
  nlohmann::ordered_json out = nlohmann::ordered_json::object();
  for (const char* name : kTableParameters) {
    const std::vector<float>& channel = image.channel(name);
    std::vector<float> values;
    double sum = 0;
    for (std::size_t i = 0; i < channel.size(); ++i)
      if (flags[i] == 0.0f && std::isfinite(channel[i]) && (!mask || (*mask)[i] != 0)) {
        values.push_back(channel[i]);
        sum += channel[i];
      }
    std::sort(values.begin(), values.end());
    if (explained) *explained = values.size();
    nlohmann::ordered_json stats;
    stats["mean"] = values.empty() ? std::numeric_limits<double>::quiet_NaN() : sum / values.size();
    for (const auto& [label, p] : kTableQuantiles) stats[label] = quantile_of_sorted(values, p);
    out[name] = stats;
  }
  return out;
}

std::string csv_field(const std::string& text) {
  if (text.find_first_of(",\"\n\r") == std::string::npos) return text;
  std::string out = "\"";
  for (char c : text) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

// A JSON value as a table cell: numbers shortest round-trip, strings as they are, null empty.
template <class Json>
std::string cell(const Json& value) {
  if (value.is_null()) return "";
  if (value.is_string()) return value.template get<std::string>();
  if (value.is_number_float()) {
    const double v = value.template get<double>();
    return std::isfinite(v) ? fmt::format("{}", v) : "";
  }
  return value.dump();
}

template <class Json>
const Json& member(const Json& object, const std::string& key) {
  static const Json null;
  if (!object.is_object()) return null;
  const auto found = object.find(key);
  return found == object.end() ? null : *found;
}

}  // namespace

nlohmann::ordered_json camera_rows(const fs::path& maps_dir, const std::vector<maps::CameraEstimate>& cameras,
                                   const fs::path& session_folder, const std::vector<RegionSpec>& regions) {
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  for (const auto& camera : cameras) {
    nlohmann::ordered_json row{{"camera", camera.camera}, {"state", camera.ok ? "ok" : "failed"},
                               {"error", camera.reason}, {"folder", camera.folder}};
    if (camera.ok) {
      const fs::path dir = maps_dir / camera.folder;
      const auto summary = nlohmann::ordered_json::parse(files::read_text_file(dir / "summary.json", "summary"));
      row["pixels"] = summary.at("pixels");
      row["explained"] = summary.at("flag_counts").at("explained");
      row["flag_counts"] = summary.at("flag_counts");
      const files::FloatImage image = files::read_exr(dir / "maps.exr");
      row["parameters"] = parameter_statistics(image);
      nlohmann::ordered_json by_region = nlohmann::ordered_json::object();
      for (const RegionSpec& region : regions) {
        const fs::path file = region_mask_file(session_folder, region, camera.camera);
        std::error_code error;
        if (!fs::exists(file, error)) {
          by_region[region.name] = {{"missing", file.string()}};
          continue;
        }
        const auto mask = read_region_mask(file, image.width, image.height);
        std::size_t explained = 0;
        auto stats = parameter_statistics(image, &mask, &explained);
        by_region[region.name] = {{"explained", explained}, {"parameters", std::move(stats)}};
      }
      if (!regions.empty()) row["regions"] = by_region;
      nlohmann::ordered_json relit = nlohmann::ordered_json::object();
      for (const auto& [illuminant, stats] : member(member(summary, "relit_delta_e94"), "by_illuminant").items())
        relit[illuminant] = {{"mean", stats.at("mean")}, {"median", stats.at("median")}, {"p95", stats.at("p95")}};
      row["relit_delta_e94"] = relit;
    }
    rows.push_back(row);
  }
  return rows;
}

std::size_t write_study_table(const Study& study, const std::string& estimator_version) {
  // Gather the records first: the flag and illuminant columns are the union of theirs.
  std::vector<std::pair<std::string, std::optional<nlohmann::ordered_json>>> records;
  std::vector<std::string> flags, illuminants;
  auto note = [](std::vector<std::string>& list, const std::string& name) {
    if (std::find(list.begin(), list.end(), name) == list.end()) list.push_back(name);
  };
  for (const auto& session : study.sessions) {
    records.emplace_back(session.name, read_record(study.dir, session.name));
    const auto& record = records.back().second;
    if (!record) continue;
    for (const auto& row : member(*record, "cameras")) {
      for (const auto& [flag, count] : member(row, "flag_counts").items()) note(flags, flag);
      for (const auto& [illuminant, stats] : member(row, "relit_delta_e94").items()) note(illuminants, illuminant);
    }
  }
  std::vector<std::string> header{"session", "subject", "time", "plan", "camera", "state", "error", "pixels", "explained"};
  for (const auto& flag : flags) header.push_back("flag_" + flag);
  for (const char* parameter : kTableParameters) {
    header.push_back(std::string(parameter) + "_mean");
    for (const auto& [label, p] : kTableQuantiles) header.push_back(std::string(parameter) + "_" + label);
  }
  for (const auto& illuminant : illuminants)
    for (const char* stat : {"mean", "median", "p95"}) header.push_back("de94_" + illuminant + "_" + stat);
  for (const auto& region : study.regions) {
    header.push_back("explained@" + region.name);
    for (const char* parameter : kTableParameters) {
      header.push_back(std::string(parameter) + "_mean@" + region.name);
      for (const auto& [label, p] : kTableQuantiles) header.push_back(std::string(parameter) + "_" + label + "@" + region.name);
    }
  }
  for (const char* column : {"estimator_version", "method", "model", "options", "input_hash", "run", "task", "host",
                             "seconds", "maps", "session_folder"})
    header.emplace_back(column);

  std::string csv;
  auto line = [&csv](const std::vector<std::string>& cells) {
    for (std::size_t i = 0; i < cells.size(); ++i) csv += (i ? "," : "") + csv_field(cells[i]);
    csv += "\n";
  };
  line(header);
  std::size_t rows = 0;
  const std::string options = options_json(study.options, study.regions).dump();
  for (const auto& [name, record] : records) {
    const nlohmann::ordered_json r = record.value_or(nlohmann::ordered_json::object());
    const std::string state = record ? r.value("state", "pending") : "pending";
    nlohmann::ordered_json cameras = member(r, "cameras");
    if (!cameras.is_array() || cameras.empty()) cameras = nlohmann::ordered_json::array({nlohmann::ordered_json::object()});
    for (const auto& row : cameras) {
      std::vector<std::string> cells{name, cell(member(r, "subject")), cell(member(r, "created")),
                                     cell(member(r, "plan")), cell(member(row, "camera"))};
      const bool camera_failed = member(row, "state") == "failed";
      cells.push_back(state == "done" && camera_failed ? "failed" : state);
      cells.push_back(camera_failed ? cell(member(row, "error")) : cell(member(r, "error")));
      cells.push_back(cell(member(row, "pixels")));
      cells.push_back(cell(member(row, "explained")));
      for (const auto& flag : flags) cells.push_back(cell(member(member(row, "flag_counts"), flag)));
      for (const char* parameter : kTableParameters) {
        const auto& stats = member(member(row, "parameters"), parameter);
        cells.push_back(cell(member(stats, "mean")));
        for (const auto& [label, p] : kTableQuantiles) cells.push_back(cell(member(stats, label)));
      }
      for (const auto& illuminant : illuminants)
        for (const char* stat : {"mean", "median", "p95"})
          cells.push_back(cell(member(member(member(row, "relit_delta_e94"), illuminant), stat)));
      for (const auto& region : study.regions) {
        const auto& r_stats = member(member(row, "regions"), region.name);
        cells.push_back(cell(member(r_stats, "explained")));
        for (const char* parameter : kTableParameters) {
          const auto& stats = member(member(r_stats, "parameters"), parameter);
          cells.push_back(cell(member(stats, "mean")));
          for (const auto& [label, p] : kTableQuantiles) cells.push_back(cell(member(stats, label)));
        }
      }
      const std::string folder = cell(member(row, "folder"));
      const bool has_maps = state == "done" && !camera_failed;
      cells.push_back(record ? cell(member(r, "estimator_version")) : estimator_version);
      cells.push_back(study.options.method);
      cells.push_back(study.options.model);
      cells.push_back(options);
      cells.push_back(cell(member(r, "input_hash")));
      cells.push_back(cell(member(r, "run")));
      cells.push_back(cell(member(r, "task")));
      cells.push_back(cell(member(r, "host")));
      cells.push_back(cell(member(r, "seconds")));
      cells.push_back(has_maps ? "sessions/" + name + (folder.empty() ? "" : "/" + folder) : "");
      cells.push_back(study.find(name)->folder.string());
      line(cells);
      ++rows;
    }
  }
  files::write_file_durably(study.dir / "study.csv", csv, nullptr);
  return rows;
}

}  // namespace chromo::cli::study
