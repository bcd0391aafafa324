#include "provenance_text.hpp"

#include <map>

#include <fmt/format.h>
#include <google/protobuf/util/json_util.h>

namespace chromo::cli {

namespace pb = chromosphere::v1;

std::string age_text(double seconds) {
  if (seconds < 0) return "unknown age";
  if (seconds < 3600) return fmt::format("{:.0f} min", seconds / 60);
  if (seconds < 48 * 3600) return fmt::format("{:.1f} h", seconds / 3600);
  return fmt::format("{:.1f} days", seconds / 86400);
}

namespace {

std::string levels_text(const pb::DriveLevels& w) {
  return fmt::format("W57 {:.3f} W40 {:.3f} W27 {:.3f} R {:.3f} G {:.3f} B {:.3f}", w.w57(), w.w40(), w.w27(), w.red(),
                     w.green(), w.blue());
}

std::string library_text(const pb::LedLibraryUsed& library) {
  if (library.kind() == "nominal")
    return "the built-in nominal library (no calibration: datasheet-class spectra, not this sphere's)";
  std::string text = library.kind();
  if (!library.created_utc().empty())
    text += fmt::format(" {} ({} before the session)", library.created_utc(), age_text(library.age_at_start_s()));
  if (!library.file().empty()) text += ", " + library.file();
  return text;
}

}  // namespace

std::string provenance_text(const pb::SessionProvenance& p, const std::string& indent) {
  if (!p.recorded()) return indent + "provenance: not recorded (a session of an older chromod)\n";
  std::string out = indent + "led library: " + library_text(p.led_library()) + "\n";
  for (const auto& [name, mix] : std::map<std::string, pb::MixUsed>(p.mixes().begin(), p.mixes().end()))
    out += fmt::format("{}mix {:<14} {}  ({})\n", indent, name, levels_text(mix.weights()), mix.origin());
  out += fmt::format("{}camera sensitivity: {}", indent, p.camera_sensitivity());
  for (const auto& [camera, source] :
       std::map<std::string, std::string>(p.camera_sensitivity_of().begin(), p.camera_sensitivity_of().end()))
    out += fmt::format(", {}: {}", camera, source);
  out += fmt::format("; white reference ρ {:.3f}\n", p.white_reflectance());
  out += fmt::format("{}plan {}, operator {}, study {}\n", indent, p.plan(),
                     p.operator_name().empty() ? "(not given)" : "\"" + p.operator_name() + "\"",
                     p.study().empty() ? "(not given)" : "\"" + p.study() + "\"");
  out += indent + "estimator: " + p.estimator_version();
  for (const auto& [key, value] :
       std::map<std::string, std::string>(p.estimator_options().begin(), p.estimator_options().end()))
    out += fmt::format(", {} {}", key, value.empty() ? "-" : value);
  return out + "\n";
}

nlohmann::json provenance_json(const pb::SessionProvenance& p) {
  if (!p.recorded()) return nullptr;
  google::protobuf::util::JsonPrintOptions options;
  options.preserve_proto_field_names = true;
  options.always_print_primitive_fields = true;
  std::string text;
  if (!google::protobuf::util::MessageToJsonString(p, &text, options).ok()) return nullptr;
  return nlohmann::json::parse(text);
}

}  // namespace chromo::cli
