// chromo results ID: where a session's maps, report and frames are.
#include <cstdio>
#include <iostream>
#include <map>

#include <nlohmann/json.hpp>

#include "chromosphere/v1/estimation.grpc.pb.h"
#include "commands.hpp"
#include "daemon_client.hpp"

namespace chromo::cli {

namespace pb = chromosphere::v1;

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
    std::string state = pb::ResultsState_Name(results.state()).substr(std::string("RESULTS_STATE_").size());
    for (auto& c : state) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    const auto& summary = results.summary();
    if (options->json) {
      nlohmann::json out{{"session_id", results.session_id()}, {"state", state},           {"reason", results.reason()},
                         {"folder", results.folder()},         {"maps_file", results.maps_file()},
                         {"report_file", results.report_file()}, {"frame_files", results.frame_files()}};
      if (results.state() == pb::RESULTS_STATE_AVAILABLE) {
        nlohmann::json relit = nlohmann::json::object();
        for (const auto& [name, s] : summary.relit_delta_e94())
          relit[name] = {{"mean", s.mean()}, {"median", s.median()}, {"p95", s.p95()}};
        out["summary"] = {{"method", summary.method()},
                          {"model", summary.model()},
                          {"pixels", summary.pixels()},
                          {"pixels_per_second", summary.pixels_per_second()},
                          {"estimate_seconds", summary.estimate_seconds()},
                          {"frames_read_back", summary.frames_read_back()},
                          {"flag_counts", std::map<std::string, std::uint64_t>(summary.flag_counts().begin(),
                                                                               summary.flag_counts().end())},
                          {"relit_delta_e94", relit}};
      }
      std::cout << out.dump(2) << "\n";
    } else {
      std::cout << "session " << results.session_id() << ": results " << state;
      if (!results.reason().empty()) std::cout << " (" << results.reason() << ")";
      std::cout << "\nfolder:  " << results.folder() << "\n";
      if (!results.maps_file().empty()) std::cout << "maps:    " << results.maps_file() << "\n";
      if (!results.report_file().empty()) std::cout << "report:  " << results.report_file() << "\n";
      std::cout << "frames:  " << results.frame_files_size() << " raw TIFFs under " << results.folder() << "/frames\n";
      if (results.state() == pb::RESULTS_STATE_AVAILABLE) {
        std::printf("estimator: %s, model %s: %llu pixels in %.2f s (%.0f pixels/s)%s\n", summary.method().c_str(),
                    summary.model().c_str(), static_cast<unsigned long long>(summary.pixels()),
                    summary.estimate_seconds(), summary.pixels_per_second(),
                    summary.frames_read_back() ? (", " + std::to_string(summary.frames_read_back()) +
                                                  " frames read back from storage").c_str()
                                               : "");
        std::cout << "flags:  ";
        for (const auto& [name, count] : std::map<std::string, std::uint64_t>(summary.flag_counts().begin(),
                                                                             summary.flag_counts().end()))
          std::cout << " " << name << " " << count;
        std::cout << "\n";
        for (const auto& [name, s] : std::map<std::string, pb::DeltaEStatistics>(summary.relit_delta_e94().begin(),
                                                                                 summary.relit_delta_e94().end()))
          std::printf("relit ΔE94 vs photograph under %-9s mean %.2f  median %.2f  p95 %.2f\n", name.c_str(),
                      s.mean(), s.median(), s.p95());
      }
    }
    if (results.state() != pb::RESULTS_STATE_AVAILABLE) exit_status = kExitFailure;
  });
}

}  // namespace chromo::cli
