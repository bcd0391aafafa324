#pragma once
// TablePreparations: each camera's tables (maps::prepare_tables) prepared on
// a thread of its own while the session goes on, so the on-line estimator's
// thread keeps taking the subject's frames and the estimate starts when the
// last one is in (issue 39).
//
// Every camera's preparation runs at once with the others', except that a
// camera whose forward-table key equals an earlier-started camera's waits
// for that camera's tables and is given them (maps::prepare_tables' earlier:
// the forward and relit tables shared in memory, not made twice; the inverse
// table is shared per key by the process anyway).
//
// Thread rules: start/started/wait_all on one thread (the estimator's); the
// preparations run on their own threads. The destructor waits for any still
// running.

#include <cstdint>
#include <functional>
#include <future>
#include <map>
#include <optional>
#include <span>
#include <string>

#include "chromo/maps/estimate_report.hpp"

namespace chromo::daemon {

class TablePreparations {
 public:
  // Both run on the camera's own thread, key first: the forward table's
  // cache key of the camera's measurement set, then the tables, given the
  // ready tables of earlier cameras with that key. Either may throw: that
  // camera then has no prepared tables (the estimate builds its own and
  // names what is wrong).
  struct Job {
    std::function<std::uint64_t()> key;
    std::function<maps::PreparedTables(std::span<const maps::PreparedTables* const> earlier)> prepare;
  };
  struct Ready {
    std::map<std::string, maps::PreparedTables> tables;  // per camera whose preparation succeeded
    std::map<std::string, double> seconds;               // per started camera: start → tables (waits included)
  };

  TablePreparations() = default;
  TablePreparations(const TablePreparations&) = delete;
  TablePreparations& operator=(const TablePreparations&) = delete;
  ~TablePreparations();  // waits for every preparation still running

  // Starts camera's preparation on a thread of its own and returns at once.
  // Throws std::invalid_argument (nothing started) for a camera already
  // started or a job without key or prepare.
  void start(const std::string& camera, Job job);
  bool started(const std::string& camera) const { return running_.count(camera) != 0; }

  // Waits for every started preparation and hands over its tables and
  // seconds; afterwards nothing is started (the next session starts afresh).
  Ready wait_all();

 private:
  struct Running {
    std::shared_future<std::optional<std::uint64_t>> key;
    std::shared_future<std::optional<maps::PreparedTables>> tables;
    std::shared_future<double> seconds;
  };
  std::map<std::string, Running> running_;
  std::vector<std::future<void>> threads_;  // in start order
};

}  // namespace chromo::daemon
