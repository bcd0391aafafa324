#include "chromo/session/session_store.hpp"
#include "chromo/files/bounded_read.hpp"

#include <algorithm>
#include <fstream>
#include <iomanip>
#include <random>
#include <sstream>

#include "chromo/files/temporary_file.hpp"

namespace chromo::session {

std::string new_session_id(const std::string& name) {
  auto now = std::chrono::system_clock::now();
  auto seconds = std::chrono::system_clock::to_time_t(now);
  std::tm tm{};
  gmtime_r(&seconds, &tm);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y%m%dT%H%M%SZ", &tm);
  static thread_local std::mt19937_64 random{std::random_device{}()};
  char suffix[8];
  std::snprintf(suffix, sizeof suffix, "%06x", static_cast<unsigned>(random() & 0xffffff));
  return std::string(stamp) + "-" + name.substr(0, 32) + "-" + suffix;
}

namespace {

std::chrono::system_clock::time_point parse_time(const std::string& text) {
  std::tm tm{};
  std::istringstream in(text);
  in >> std::get_time(&tm, "%Y-%m-%dT%H:%M:%S");
  if (in.fail()) return {};
  return std::chrono::system_clock::from_time_t(timegm(&tm));
}
}  // namespace

int session_format_version(const nlohmann::json& session, const std::filesystem::path& file) {
  static const std::string kPrefix = "chromosphere-session/";
  const auto format = session.find("format");
  if (format == session.end() || !format->is_string())
    throw std::invalid_argument(file.string() + ": format: missing (expected \"" + kPrefix + "N\")");
  const std::string text = format->get<std::string>();
  const std::string number = text.rfind(kPrefix, 0) == 0 ? text.substr(kPrefix.size()) : "";
  int version = 0;
  if (!number.empty() && number.size() <= 3 && number.find_first_not_of("0123456789") == std::string::npos)
    version = std::stoi(number);
  if (version < 1 || version > kSessionFormatVersion)
    throw std::invalid_argument(file.string() + ": format: \"" + text.substr(0, 64) + "\" is not a session format " +
                                "this version reads (" + kPrefix + "1 to " + kPrefix +
                                std::to_string(kSessionFormatVersion) + ")");
  return version;
}

SessionStore::SessionStore(std::filesystem::path root, files::StorageBudget* budget) : root_(std::move(root)), budget_(budget) {
  std::filesystem::create_directories(root_);
}

SessionStore::Created SessionStore::create(const SessionPlan& plan, const std::string& subject,
                                           const nlohmann::json& devices, const SessionProvenance* provenance) {
  Created created;
  created.id = new_session_id(plan.name);
  created.folder = root_ / created.id;
  if (!std::filesystem::create_directory(created.folder))
    throw std::runtime_error("session folder " + created.folder.string() + " already exists");
  // A start refused while the folder is being filled (a full disk, the
  // storage budget) leaves no folder behind: it is ours, made just now.
  try {
    fill_new_session_folder(created, plan, subject, devices, provenance);
  } catch (...) {
    created.journal.reset();
    std::error_code ignored;
    std::filesystem::remove_all(created.folder, ignored);
    throw;
  }
  return created;
}

void SessionStore::fill_new_session_folder(Created& created, const SessionPlan& plan, const std::string& subject,
                                           const nlohmann::json& devices, const SessionProvenance* provenance) {
  files::fsync_directory(root_);
  nlohmann::json session{{"format", "chromosphere-session/" + std::to_string(kSessionFormatVersion)},
                         {"id", created.id},
                         {"name", plan.name},
                         {"subject", subject},
                         {"created", utc_timestamp_now()},
                         {"plan", to_json(plan)},
                         {"devices", devices}};
  if (provenance) session["provenance"] = to_json(*provenance);
  files::write_file_durably(created.folder / "session.json", session.dump(2) + "\n", budget_);
  created.journal = std::make_unique<Journal>(created.folder / "journal.jsonl", budget_);
  created.journal->append({{"type", "state"}, {"state", "pending"}});
}

SessionInfo SessionStore::read_session(const std::filesystem::path& folder) const {
  if (!std::filesystem::exists(folder / "session.json")) throw std::runtime_error(folder.string() + ": no session.json");
  auto session = nlohmann::json::parse(files::read_text_file(folder / "session.json", "JSON"), nullptr, false);
  if (!session.is_object() || !session.contains("id"))
    throw std::runtime_error(folder.string() + "/session.json: not a session description");
  SessionInfo info;
  try {
    info.format_version = session_format_version(session, folder / "session.json");
  } catch (const std::invalid_argument& error) {
    throw std::runtime_error(error.what());
  }
  info.record.id = session.value("id", "");
  info.record.name = session.value("name", "");
  info.record.kind = OperationKind::kSession;
  info.record.folder = std::filesystem::absolute(folder).string();
  info.record.created = parse_time(session.value("created", ""));
  info.record.updated = info.record.created;
  info.subject = session.value("subject", "");
  info.record.subject = info.subject;
  if (session.contains("provenance")) {
    try {
      info.provenance = provenance_from_json(session.at("provenance"));
    } catch (const std::invalid_argument& error) {
      throw std::runtime_error(folder.string() + "/session.json: " + error.what());
    }
    info.record.study = info.provenance.study;
    info.record.operator_name = info.provenance.operator_name;
  }
  info.plan = plan_from_json(session.at("plan"));
  for (const auto& step : info.plan.steps) info.steps.push_back({step.name, step.role, false, 0});
  info.record.step_count = static_cast<int>(info.plan.steps.size());
  info.record.expected_frames = 0;

  // The journal streamed (a long session's is tens of MB): each record is
  // taken into the typed SessionInfo and dropped.
  SessionTimelineBuilder timeline;
  const auto journal = for_each_journal_record(folder / "journal.jsonl", [&](nlohmann::json&& record) {
    timeline.add(record);
    const std::string type = record.value("type", "");
    if (record.contains("t")) info.record.updated = parse_time(record.value("t", ""));
    if (type == "state") {
      if (auto state = parse_state(record.value("state", ""))) info.record.state = *state;
      info.record.message = record.value("message", "");
      info.record.error = record.value("error", "");
    } else if (type == "session_started") {
      info.record.expected_frames = record.value("expected_frames", 0ull);
    } else if (type == "frame") {
      ++info.record.counters.stored;
      ++info.record.counters.received;
      try {
        FrameRecord frame = frame_record_from_json(record);
        const int index = frame.step_index;
        if (index >= 0 && index < static_cast<int>(info.steps.size())) ++info.steps[static_cast<std::size_t>(index)].frames_stored;
        info.frames.push_back(std::move(frame));
      } catch (const std::invalid_argument& error) {
        if (info.malformed_frame_records++ == 0) info.malformed_frame_error = error.what();
      }
    } else if (type == "frame_lost") {
      ++info.record.counters.lost;
      ++info.record.counters.lost_reasons[record.value("reason", "unknown")];
    } else if (type == "step_started") {
      info.record.step_index = record.value("index", -1);
    } else if (type == "step_completed") {
      int index = record.value("index", -1);
      if (index >= 0 && index < static_cast<int>(info.steps.size())) info.steps[static_cast<std::size_t>(index)].completed = true;
    } else if (type == "counters") {
      // received, stored and lost are counted from the frame records themselves.
      PipelineCounters recorded = counters_from_record(record);
      PipelineCounters& counters = info.record.counters;
      recorded.received = counters.received, recorded.stored = counters.stored, recorded.lost = counters.lost;
      recorded.lost_reasons = std::move(counters.lost_reasons);
      counters = std::move(recorded);
    } else if (type == "results") {
      info.results = std::move(record);
    }
  });
  info.torn_journal_tail = journal.torn_tail;
  info.timeline = timeline.result();
  std::size_t completed = 0;
  for (const auto& step : info.steps) completed += step.completed ? 1 : 0;
  info.record.progress = info.steps.empty() ? 0 : static_cast<double>(completed) / static_cast<double>(info.steps.size());
  if (info.record.state == OperationState::kSucceeded) info.record.progress = 1;
  info.record.eta_seconds = is_final(info.record.state) ? 0 : -1;
  return info;
}

std::vector<SessionInfo> SessionStore::recover(std::vector<std::string>* skipped) {
  namespace fs = std::filesystem;
  std::vector<SessionInfo> sessions;
  for (const auto& entry : fs::directory_iterator(root_)) {
    // One folder's trouble (issue 40: a frame linked to itself stopped chromod
    // from starting) skips that folder only.
    try {
      std::error_code unreadable;
      if (!fs::is_directory(entry.symlink_status(unreadable)) || unreadable) continue;
      if (!fs::is_regular_file(fs::symlink_status(entry.path() / "session.json", unreadable)) || unreadable) continue;
      // Leftover temporary files of writes a crash interrupted are not part of the session.
      files::remove_leftover_temporaries(entry.path(), files::Subfolders::kInclude);
      SessionInfo info;
      try {
        info = read_session(entry.path());
      } catch (const std::exception&) {
        continue;  // not a readable session (e.g. a crash between mkdir and session.json)
      }
      // Sessions are fetched by folder name: a folder whose session.json
      // names another id (a copy, an edited id such as "../../etc") would be
      // listed under an id that fetches something else, or nothing.
      if (info.record.id != entry.path().filename().string())
        throw std::runtime_error("session.json names the id \"" + info.record.id.substr(0, 80) +
                                 "\", not the folder's name (a copied or edited folder)");
      if (!is_final(info.record.state)) {
        Journal journal(entry.path() / "journal.jsonl", budget_);
        const std::string message = "the daemon stopped while this session was " + state_name(info.record.state);
        journal.append({{"type", "state"}, {"state", "interrupted"}, {"message", message}});
        info.record.state = OperationState::kInterrupted;
        info.record.message = message;
        info.record.eta_seconds = 0;
      }
      sessions.push_back(std::move(info));
    } catch (const std::exception& error) {
      if (skipped) skipped->push_back(entry.path().string() + ": " + error.what());
    }
  }
  std::sort(sessions.begin(), sessions.end(), [](const auto& a, const auto& b) { return a.record.id > b.record.id; });
  return sessions;
}

}  // namespace chromo::session
