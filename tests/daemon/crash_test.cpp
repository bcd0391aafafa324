// kill -9 of chromod (on its built-in virtual lab: real protocols) in the
// middle of a session or a calibration run, then a restart: the folder is
// intact, says which steps completed, and the operation is reported
// interrupted.
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>

#include <grpcpp/grpcpp.h>

#include "chromo/session/frame_files.hpp"
#include "chromo/session/session_store.hpp"
#include "chromosphere/v1/calibration.grpc.pb.h"
#include "chromosphere/v1/operations.grpc.pb.h"
#include "chromosphere/v1/sessions.grpc.pb.h"
#include "test_lab.hpp"

namespace chromo::daemon {
namespace {

namespace pb = chromosphere::v1;

// posix_spawn, not fork: this process has gRPC threads, and a forked child
// must not touch locks they may hold.
pid_t spawn_chromod(const std::filesystem::path& directory) {
  const std::string log = (directory / "chromod.log").string(), socket = (directory / "s.sock").string(),
                    sessions = (directory / "sessions").string();
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  // Never keep the test runner's pipes open in the child (ctest waits for them).
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  std::vector<std::string> arguments{CHROMOD, "--socket", socket, "--sessions-dir", sessions};
  std::vector<char*> argv;
  for (auto& argument : arguments) argv.push_back(argument.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  int result = posix_spawn(&pid, CHROMOD, &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  EXPECT_EQ(result, 0);
  return pid;
}

std::shared_ptr<grpc::Channel> connect(const std::filesystem::path& directory) {
  // A local subchannel pool: a new channel must not reuse the dead daemon's connection.
  grpc::ChannelArguments arguments;
  arguments.SetInt(GRPC_ARG_USE_LOCAL_SUBCHANNEL_POOL, 1);
  auto channel = grpc::CreateCustomChannel("unix:" + (directory / "s.sock").string(), grpc::InsecureChannelCredentials(),
                                           arguments);
  // chromod starts the virtual lab (scene, camera simulator, Aravis discovery) before it listens.
  EXPECT_TRUE(channel->WaitForConnected(std::chrono::system_clock::now() + std::chrono::seconds(30)));
  return channel;
}

// Kills the spawned chromod (if still running) when a test ends, even by a failed ASSERT.
struct KillOnExit {
  pid_t& pid;
  ~KillOnExit() {
    if (pid > 0 && ::kill(pid, SIGKILL) == 0) ::waitpid(pid, nullptr, 0);
  }
};

TEST(Crash, KillNineMidSessionThenRestartReportsInterruptedAndTheFolderIsIntact) {
  auto directory = testing::fresh_directory("crash");
  pid_t pid = spawn_chromod(directory);
  KillOnExit kill_on_exit{pid};
  auto channel = connect(directory);
  pb::StartSessionRequest request;
  request.set_standard(true);
  request.set_exposure_us(2000);
  request.set_frames_per_camera(30);
  request.set_reference_frames(30);
  pb::Operation started;
  {
    grpc::ClientContext context;
    ASSERT_TRUE(pb::SessionService::NewStub(channel)->StartSession(&context, request, &started).ok());
  }
  // Wait until the session is well into its second step, then kill -9.
  auto operations = pb::OperationService::NewStub(channel);
  for (int i = 0; i < 1500; ++i) {
    grpc::ClientContext context;
    pb::GetOperationRequest get;
    get.set_id(started.id());
    pb::Operation now;
    ASSERT_TRUE(operations->GetOperation(&context, get, &now).ok());
    if (now.counters().stored() >= 45) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_EQ(::kill(pid, SIGKILL), 0);
  int status = 0;
  ::waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status));

  pid = spawn_chromod(directory);
  channel = connect(directory);
  grpc::ClientContext context;
  pb::GetSessionRequest get;
  get.set_id(started.id());
  get.set_include_frames(true);
  pb::SessionDetail detail;
  auto got = pb::SessionService::NewStub(channel)->GetSession(&context, get, &detail);
  ASSERT_TRUE(got.ok()) << got.error_message();
  EXPECT_EQ(detail.summary().operation().state(), pb::OPERATION_STATE_INTERRUPTED);
  EXPECT_TRUE(detail.steps(0).completed());
  EXPECT_EQ(detail.steps(0).frames_stored(), 30u);
  EXPECT_FALSE(detail.steps(6).completed());
  EXPECT_GE(detail.frames_size(), 45);
  // Every acknowledged frame reads back in full.
  const std::filesystem::path folder = detail.summary().folder();
  for (const auto& frame : detail.frames()) {
    auto image = session::read_tiff(folder / frame.file());
    EXPECT_EQ(image.data.size(), static_cast<std::size_t>(image.width * image.height * 2)) << frame.file();
  }
  // No temporary files left, and the journal holds the interruption record.
  for (const auto& file : std::filesystem::recursive_directory_iterator(folder))
    EXPECT_EQ(file.path().string().find(".tmp-"), std::string::npos);
  auto journal = session::read_journal(folder / "journal.jsonl");
  EXPECT_EQ(journal.records.back()["state"], "interrupted");

  ::kill(pid, SIGTERM);
  ::waitpid(pid, &status, 0);
  pid = 0;
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  std::filesystem::remove_all(directory);
}

// Issue 40, row 4: one frame replaced by a link to itself stopped chromod
// from starting (exit 1, "Too many levels of symbolic links"). The real
// chromod starts on such a folder and lists the session.
TEST(Crash, ALoopOfSymbolicLinksInTheSessionsFolderDoesNotStopChromodFromStarting) {
  auto directory = testing::fresh_directory("symlink-loop");
  const auto sessions = directory / "sessions";
  std::string id;
  {
    session::SessionStore store(sessions, nullptr);
    auto created = store.create(testing::quick_standard_plan(1), "loop test", nlohmann::json::object());
    id = created.id;
    std::filesystem::create_symlink("frame-0000.tiff", created.folder / "frame-0000.tiff");  // itself
    std::filesystem::create_directories(created.folder / "results");
    std::filesystem::create_symlink("a", created.folder / "results" / "b");
    std::filesystem::create_symlink("b", created.folder / "results" / "a");
  }
  std::filesystem::create_symlink("loop", sessions / "loop");  // and one beside the sessions
  pid_t pid = spawn_chromod(directory);
  KillOnExit kill_on_exit{pid};
  auto channel = connect(directory);
  grpc::ClientContext context;
  pb::ListSessionsResponse listed;
  ASSERT_TRUE(pb::SessionService::NewStub(channel)->ListSessions(&context, pb::ListSessionsRequest{}, &listed).ok());
  ASSERT_EQ(listed.sessions_size(), 1);
  EXPECT_EQ(listed.sessions(0).id(), id);
  EXPECT_EQ(listed.sessions(0).operation().state(), pb::OPERATION_STATE_INTERRUPTED);  // it never ran
  int status = 0;
  ::kill(pid, SIGTERM);
  ::waitpid(pid, &status, 0);
  pid = 0;
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  std::filesystem::remove_all(directory);
}

TEST(Crash, KillNineMidCalibrationThenRestartReportsItInterrupted) {
  auto directory = testing::fresh_directory("crash-calibration");
  pid_t pid = spawn_chromod(directory);
  KillOnExit kill_on_exit{pid};
  auto channel = connect(directory);
  pb::StartCalibrationRequest request;
  request.set_warmup_ms(2000);  // long enough to be killed in the middle
  pb::Operation started;
  {
    grpc::ClientContext context;
    ASSERT_TRUE(pb::CalibrationService::NewStub(channel)->StartCalibration(&context, request, &started).ok());
  }
  auto operations = pb::OperationService::NewStub(channel);
  auto get = [&](pb::Operation* now) {
    grpc::ClientContext context;
    pb::GetOperationRequest request;
    request.set_id(started.id());
    return operations->GetOperation(&context, request, now);
  };
  pb::Operation now;
  for (int i = 0; i < 1500; ++i) {
    ASSERT_TRUE(get(&now).ok());
    if (now.progress() > 0.1) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_EQ(now.state(), pb::OPERATION_STATE_RUNNING);
  ASSERT_EQ(::kill(pid, SIGKILL), 0);
  ::waitpid(pid, nullptr, 0);

  pid = spawn_chromod(directory);
  channel = connect(directory);
  operations = pb::OperationService::NewStub(channel);
  ASSERT_TRUE(get(&now).ok());
  EXPECT_EQ(now.state(), pb::OPERATION_STATE_INTERRUPTED);
  EXPECT_EQ(now.kind(), pb::OPERATION_KIND_CALIBRATION);
  const std::filesystem::path folder = now.folder();
  EXPECT_FALSE(std::filesystem::exists(folder / "led-library.json"));
  std::ifstream in(folder / "calibration.json");
  EXPECT_EQ(nlohmann::json::parse(in)["state"], "interrupted");
  int status = 0;
  ::kill(pid, SIGTERM);
  ::waitpid(pid, &status, 0);
  pid = 0;
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  std::filesystem::remove_all(directory);
}

}  // namespace
}  // namespace chromo::daemon
