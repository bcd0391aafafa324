// chromo results ID: where a session's maps, report and frames are.
#include <iostream>

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
    if (options->json) {
      nlohmann::json out{{"session_id", results.session_id()}, {"state", state},           {"reason", results.reason()},
                         {"folder", results.folder()},         {"maps_file", results.maps_file()},
                         {"report_file", results.report_file()}, {"frame_files", results.frame_files()}};
      std::cout << out.dump(2) << "\n";
    } else {
      std::cout << "session " << results.session_id() << ": results " << state;
      if (!results.reason().empty()) std::cout << " (" << results.reason() << ")";
      std::cout << "\nfolder:  " << results.folder() << "\n";
      if (!results.maps_file().empty()) std::cout << "maps:    " << results.maps_file() << "\n";
      if (!results.report_file().empty()) std::cout << "report:  " << results.report_file() << "\n";
      std::cout << "frames:  " << results.frame_files_size() << " raw TIFFs under " << results.folder() << "/frames\n";
    }
    if (results.state() != pb::RESULTS_STATE_AVAILABLE) exit_status = kExitFailure;
  });
}

}  // namespace chromo::cli
