#include "chromo/daemon/internal/operations/table_cache_references.hpp"

#include <sys/stat.h>

#include <nlohmann/json.hpp>

#include "chromo/files/bounded_read.hpp"
#include "chromo/session/session_plan.hpp"

namespace chromo::daemon {

namespace {
// A results summary.json as JSON; null when absent, unreadable or not JSON.
nlohmann::json read_results_summary(const std::filesystem::path& file, int& summaries_read) {
  std::string text;
  try {
    text = files::read_text_file(file, "JSON");
  } catch (const std::exception&) {
    return nullptr;  // no results (or unreadable ones): no cache entry to name
  }
  ++summaries_read;
  const auto summary = nlohmann::json::parse(text, nullptr, false);
  return summary.is_discarded() || !summary.is_object() ? nlohmann::json() : summary;
}

// The cache file names a summary's "table" names (table.key and table.inverse_key).
void add_table_entries(const nlohmann::json& summary, std::set<std::string>& names) {
  if (!summary.is_object() || !summary.contains("table") || !summary["table"].is_object()) return;
  const auto hex = [](const nlohmann::json& key) {
    const std::string text = key.is_string() ? key.get<std::string>() : std::string();
    return text.size() == 16 && text.find_first_not_of("0123456789abcdef") == std::string::npos ? text : std::string();
  };
  const auto& table = summary["table"];
  if (auto key = hex(table.value("key", nlohmann::json())); !key.empty()) names.insert("forward_table_" + key + ".bin");
  if (auto key = hex(table.value("inverse_key", nlohmann::json())); !key.empty())
    names.insert("inverse_table_" + key + ".bin");
}
}  // namespace

const std::set<std::string>& TableCacheReferences::entries_of(const std::filesystem::path& folder) {
  const std::filesystem::path index = folder / "results" / "summary.json";
  Kept now;
  if (struct stat facts{}; ::stat(index.c_str(), &facts) == 0 && S_ISREG(facts.st_mode)) {
    // Results are committed by rename: a re-estimate is a new inode as well as a new time.
    now.present = true;
    now.inode = facts.st_ino;
    now.modified_ns = facts.st_mtim.tv_sec * 1'000'000'000LL + facts.st_mtim.tv_nsec;
    now.bytes = facts.st_size;
  }
  auto kept = kept_.find(folder);
  if (kept != kept_.end() && kept->second.present == now.present && kept->second.inode == now.inode &&
      kept->second.modified_ns == now.modified_ns && kept->second.bytes == now.bytes)
    return kept->second.entries;
  if (now.present) {
    const nlohmann::json summary = read_results_summary(index, summaries_read_);
    add_table_entries(summary, now.entries);
    if (summary.is_object() && summary.contains("cameras") && summary["cameras"].is_array())
      for (const auto& camera : summary["cameras"]) {
        if (!camera.is_object() || !camera.contains("folder") || !camera["folder"].is_string()) continue;
        const std::string name = camera["folder"].get<std::string>();
        if (!session::is_valid_name(name) || name == "." || name == "..") continue;
        add_table_entries(read_results_summary(folder / "results" / name / "summary.json", summaries_read_),
                          now.entries);
      }
  }
  return kept_.insert_or_assign(folder, std::move(now)).first->second.entries;
}

std::set<std::string> TableCacheReferences::named_only_by(const std::filesystem::path& root,
                                                          const std::filesystem::path& folder) {
  std::set<std::string> only_here = entries_of(folder);
  for (const auto& entry : std::filesystem::directory_iterator(root))
    if (entry.is_directory() && entry.path() != folder)
      for (const auto& name : entries_of(entry.path())) only_here.erase(name);
  return only_here;
}

void TableCacheReferences::forget(const std::filesystem::path& folder) { kept_.erase(folder); }

}  // namespace chromo::daemon
