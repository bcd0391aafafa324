#include "chromo/daemon/internal/capture/table_preparations.hpp"

#include <chrono>
#include <memory>
#include <stdexcept>
#include <vector>

namespace chromo::daemon {

TablePreparations::~TablePreparations() {
  for (auto& thread : threads_) thread.wait();
}

void TablePreparations::start(const std::string& camera, Job job) {
  if (running_.count(camera)) throw std::invalid_argument("table preparation: camera " + camera + " already started");
  if (!job.key || !job.prepare) throw std::invalid_argument("table preparation of " + camera + ": no key or prepare");
  auto key = std::make_shared<std::promise<std::optional<std::uint64_t>>>();
  auto tables = std::make_shared<std::promise<std::optional<maps::PreparedTables>>>();
  auto seconds = std::make_shared<std::promise<double>>();
  std::vector<Running> earlier;
  for (const auto& [name, running] : running_) earlier.push_back(running);
  running_[camera] = {key->get_future().share(), tables->get_future().share(), seconds->get_future().share()};
  const auto t0 = std::chrono::steady_clock::now();
  threads_.push_back(std::async(std::launch::async, [job = std::move(job), earlier = std::move(earlier), key, tables,
                                                     seconds, t0]() mutable {
    std::optional<std::uint64_t> own_key;
    try {
      own_key = job.key();
    } catch (const std::exception&) {
      // No key: no tables; the estimate names what is wrong.
    }
    key->set_value(own_key);
    std::optional<maps::PreparedTables> own;
    if (own_key) {
      // Earlier cameras of the same key lend their tables: wait for them (the shared futures keep them alive).
      std::vector<const maps::PreparedTables*> same_key;
      for (const Running& other : earlier) {
        const auto other_key = other.key.get();
        if (other_key && *other_key == *own_key && other.tables.get()) same_key.push_back(&*other.tables.get());
      }
      try {
        own = job.prepare(same_key);
      } catch (const std::exception&) {
        // As above: the estimate builds its own tables and names the error.
      }
    }
    job = {};  // the captures the job holds go back now, not at wait_all
    tables->set_value(std::move(own));
    seconds->set_value(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }));
}

TablePreparations::Ready TablePreparations::wait_all() {
  Ready ready;
  for (const auto& [camera, running] : running_) {
    if (const auto& tables = running.tables.get()) ready.tables.emplace(camera, *tables);
    ready.seconds[camera] = running.seconds.get();
  }
  for (auto& thread : threads_) thread.wait();
  running_.clear();
  threads_.clear();
  return ready;
}

}  // namespace chromo::daemon
