// TablePreparations (daemon/internal/capture/table_preparations.hpp): each
// camera's tables prepared on a thread of its own, off the caller's thread;
// cameras of different keys at once, a camera of an earlier camera's key
// given that camera's tables. Fake jobs: no table is built. The waits on
// futures are bounded only so that a wrong implementation fails instead of
// hanging; nothing asserts a time.
#include <gtest/gtest.h>

#include <chrono>
#include <future>
#include <stdexcept>
#include <thread>

#include "chromo/daemon/internal/capture/table_preparations.hpp"

namespace chromo::daemon {
namespace {

constexpr auto kGuard = std::chrono::seconds(30);

// Tables told apart by their inverter_seconds.
maps::PreparedTables marked(double mark) {
  maps::PreparedTables tables;
  tables.inverter_seconds = mark;
  return tables;
}

TEST(TablePreparations, CamerasOfDifferentKeysRunAtOnceOffTheCallersThread) {
  TablePreparations preparations;
  std::promise<void> second_started;
  auto second_started_future = second_started.get_future();
  std::thread::id first_thread;
  // The first waits for the second to start: one after the other, it would give up.
  preparations.start("cam0", {[] { return std::uint64_t{1}; },
                              [&](std::span<const maps::PreparedTables* const> earlier) {
                                first_thread = std::this_thread::get_id();
                                EXPECT_TRUE(earlier.empty());
                                if (second_started_future.wait_for(kGuard) != std::future_status::ready)
                                  throw std::runtime_error("not at once");
                                return marked(10);
                              }});
  preparations.start("cam1", {[] { return std::uint64_t{2}; },
                              [&](std::span<const maps::PreparedTables* const> earlier) {
                                EXPECT_TRUE(earlier.empty());  // another key lends nothing
                                second_started.set_value();
                                return marked(20);
                              }});
  EXPECT_TRUE(preparations.started("cam0"));
  EXPECT_FALSE(preparations.started("cam2"));
  const TablePreparations::Ready ready = preparations.wait_all();
  EXPECT_NE(first_thread, std::this_thread::get_id());
  ASSERT_EQ(ready.tables.size(), 2u);
  EXPECT_EQ(ready.tables.at("cam0").inverter_seconds, 10);
  EXPECT_EQ(ready.tables.at("cam1").inverter_seconds, 20);
  EXPECT_EQ(ready.seconds.size(), 2u);
  EXPECT_FALSE(preparations.started("cam0"));  // handed over: the next session starts afresh
}

TEST(TablePreparations, ACameraOfAnEarlierCamerasKeyIsGivenItsTablesAndAFailureOnlyLosesItsOwn) {
  TablePreparations preparations;
  std::promise<void> release_first;
  auto release = release_first.get_future().share();
  preparations.start("cam0", {[] { return std::uint64_t{7}; },
                              [release](std::span<const maps::PreparedTables* const>) {
                                release.wait_for(kGuard);
                                return marked(1);
                              }});
  preparations.start("cam1", {[] { return std::uint64_t{7}; },
                              [](std::span<const maps::PreparedTables* const> earlier) {
                                // Given cam0's finished tables, not started beside them.
                                if (earlier.size() != 1) throw std::runtime_error("no earlier tables");
                                return marked(earlier.front()->inverter_seconds + 1);
                              }});
  preparations.start("cam2", {[]() -> std::uint64_t { throw std::runtime_error("unusable references"); },
                              [](std::span<const maps::PreparedTables* const>) { return marked(99); }});
  EXPECT_THROW(preparations.start("cam0", {[] { return std::uint64_t{7}; },
                                           [](std::span<const maps::PreparedTables* const>) { return marked(5); }}),
               std::invalid_argument);
  EXPECT_THROW(preparations.start("cam3", {}), std::invalid_argument);
  EXPECT_FALSE(preparations.started("cam3"));
  release_first.set_value();
  const TablePreparations::Ready ready = preparations.wait_all();
  ASSERT_EQ(ready.tables.size(), 2u);
  EXPECT_EQ(ready.tables.at("cam0").inverter_seconds, 1);
  EXPECT_EQ(ready.tables.at("cam1").inverter_seconds, 2);
  EXPECT_EQ(ready.tables.count("cam2"), 0u);  // its own failure: no tables, the others kept
  EXPECT_EQ(ready.seconds.size(), 3u);
}

}  // namespace
}  // namespace chromo::daemon
