// chromo results ID: where a session's maps, report and frames are.
#include <cstdio>
#include <iostream>
#include <map>

#include <nlohmann/json.hpp>

#include "chromosphere/v1/estimation.grpc.pb.h"
#include "commands.hpp"
#include "daemon_client.hpp"
#include "provenance_text.hpp"

namespace chromo::cli {

namespace pb = chromosphere::v1;

namespace {

std::string state_word(pb::ResultsState state) {
  std::string word = pb::ResultsState_Name(state).substr(std::string("RESULTS_STATE_").size());
  for (auto& c : word) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return word;
}

nlohmann::json summary_json(const pb::ResultsSummary& summary) {
  nlohmann::json relit = nlohmann::json::object();
  for (const auto& [name, s] : summary.relit_delta_e94())
  {
    relit[name] = {{"mean", s.mean()}, {"median", s.median()}, {"p95", s.p95()}};
    if (s.has_photograph_noise_mean()) relit[name]["photograph_noise_mean"] = s.photograph_noise_mean();
    if (s.has_beyond_noise_rms()) relit[name]["beyond_noise_rms"] = s.beyond_noise_rms();
    if (s.has_block_means_mean()) relit[name]["block_means_mean"] = s.block_means_mean();
  }
  return {{"method", summary.method()},
          {"model", summary.model()},
          {"pixels", summary.pixels()},
          {"pixels_per_second", summary.pixels_per_second()},
          {"estimate_seconds", summary.estimate_seconds()},
          {"frames_read_back", summary.frames_read_back()},
          {"highlights", {{"detection", summary.highlight_detection()}, {"pixels", summary.highlight_pixels()}}},
          {"flag_counts",
           std::map<std::string, std::uint64_t>(summary.flag_counts().begin(), summary.flag_counts().end())},
          {"relit_delta_e94", relit}};
}

// The estimator's line, flags and relit ΔE94, each line after `indent`.
void print_summary(const pb::ResultsSummary& summary, const std::string& indent) {
  std::printf("%sestimator: %s, model %s: %llu pixels in %.2f s (%.0f pixels/s)%s\n", indent.c_str(),
              summary.method().c_str(), summary.model().c_str(), static_cast<unsigned long long>(summary.pixels()),
              summary.estimate_seconds(), summary.pixels_per_second(),
              summary.frames_read_back()
                  ? (", " + std::to_string(summary.frames_read_back()) + " frames read back from storage").c_str()
                  : "");
  std::cout << indent << "flags:  ";
  for (const auto& [name, count] :
       std::map<std::string, std::uint64_t>(summary.flag_counts().begin(), summary.flag_counts().end()))
    std::cout << " " << name << " " << count;
  std::cout << "\n";
  if (!summary.highlight_detection().empty())
    std::printf("%shighlights: %s, %llu pixels (%s)\n", indent.c_str(), summary.highlight_detection().c_str(),
                static_cast<unsigned long long>(summary.highlight_pixels()),
                summary.highlight_detection() == "optical"
                    ? "parallel − cross: maps.exr surface and highlight, information only"
                    : "no parallel capture: the estimator's specular flag");
  for (const auto& [name, s] :
       std::map<std::string, pb::DeltaEStatistics>(summary.relit_delta_e94().begin(), summary.relit_delta_e94().end()))
  {
    std::printf("%srelit ΔE94 vs photograph under %-9s mean %.2f  median %.2f  p95 %.2f", indent.c_str(), name.c_str(),
                s.mean(), s.median(), s.p95());
    // Per pixel a dim photograph is mostly its own noise; 8×8 block means keep only the systematic part.
    if (s.has_block_means_mean()) std::printf("  8×8 block means %.2f", s.block_means_mean());
    std::printf("\n");
  }
}

}  // namespace

void add_results_command(CLI::App& app, int& exit_status) {
  auto* command = app.add_subcommand("results", "a session's results (maps, report, frames) from chromod");
  struct Options {
    DaemonAddress address;
    std::string id;
    bool json = false;
  };
  auto options = std::make_shared<Options>();
  add_daemon_options(*command, options->address);
  command->add_option("id", options->id, "session id")->required();
  command->add_flag("--json", options->json, "print one JSON object");
  command->callback([&exit_status, options] {
    DaemonConnection daemon(options->address);
    pb::GetResultsRequest request;
    request.set_session_id(options->id);
    pb::Results results;
    auto status = pb::ResultsService::NewStub(daemon.channel())->GetResults(daemon.context().get(), request, &results);
    if (!status.ok()) {
      exit_status = report_failure("results", status);
      return;
    }
    const std::string state = state_word(results.state());
    const auto& summary = results.summary();
    if (options->json) {
      nlohmann::json out{{"session_id", results.session_id()}, {"state", state},           {"reason", results.reason()},
                         {"folder", results.folder()},         {"maps_file", results.maps_file()},
                         {"report_file", results.report_file()}, {"frame_files", results.frame_files()}};
      if (results.state() == pb::RESULTS_STATE_AVAILABLE) out["summary"] = summary_json(summary);
      out["provenance"] = provenance_json(results.provenance());
      out["cameras"] = nlohmann::json::array();
      for (const auto& camera : results.cameras()) {
        nlohmann::json entry{{"camera", camera.camera()}, {"state", state_word(camera.state())}};
        if (camera.state() == pb::RESULTS_STATE_AVAILABLE) {
          entry["maps_file"] = camera.maps_file();
          entry["report_file"] = camera.report_file();
          entry["camera_sensitivity"] = camera.camera_sensitivity();
          entry["shared_with"] = camera.shared_with();
          entry["summary"] = summary_json(camera.summary());
        } else {
          entry["reason"] = camera.reason();
        }
        out["cameras"].push_back(entry);
      }
      std::cout << out.dump(2) << "\n";
    } else {
      std::cout << "session " << results.session_id() << ": results " << state;
      if (!results.reason().empty()) std::cout << " (" << results.reason() << ")";
      std::cout << "\nfolder:  " << results.folder() << "\n";
      const bool several = results.cameras_size() > 1;
      if (!several && !results.maps_file().empty()) std::cout << "maps:    " << results.maps_file() << "\n";
      if (!results.report_file().empty()) std::cout << "report:  " << results.report_file() << "\n";
      std::cout << "frames:  " << results.frame_files_size() << " raw TIFFs under " << results.folder() << "/frames\n";
      std::cout << provenance_text(results.provenance());
      if (!several && results.state() == pb::RESULTS_STATE_AVAILABLE) print_summary(summary, "");
      if (several)
        for (const auto& camera : results.cameras()) {
          std::cout << "camera " << camera.camera() << ": " << state_word(camera.state());
          if (camera.state() != pb::RESULTS_STATE_AVAILABLE) {
            std::cout << " (" << camera.reason() << ")\n";
            continue;
          }
          std::cout << ", sensitivity " << camera.camera_sensitivity();
          if (!camera.shared_with().empty()) std::cout << " (tables shared with " << camera.shared_with() << ")";
          std::cout << "\n  maps:    " << camera.maps_file() << "\n  report:  " << camera.report_file() << "\n";
          print_summary(camera.summary(), "  ");
        }
    }
    if (results.state() != pb::RESULTS_STATE_AVAILABLE) exit_status = kExitFailure;
  });
}

}  // namespace chromo::cli
