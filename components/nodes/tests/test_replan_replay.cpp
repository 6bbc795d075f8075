// ddsnav-replan-replay on a small recording written here: the first plan, a shorter route's answer and a replan for a
// blocked trajectory on a 2-D world with nothing mapped. Runs the binary (no DDS).
#include "ddsnav/nodes/convert.hpp"
#include "run_tool.hpp"

#include <ddsnav/msg/messages.hpp>
#include <ddsnav/record/mcap.hpp>

#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace {

using namespace ddsnav;
namespace fs = std::filesystem;

class ReplanReplay : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("ddsnav-replan-replay-" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    std::ofstream(dir_ / "world.yaml") << ddsnav::testing::kOpenYard2d;
    const std::string file = (dir_ / "run.mcap").string();
    record::McapWriter w(file);
    const auto requests = w.addChannel(w.addSchema("ddsnav::msg::PlanRequest", "omgidl", ""), "planning/request", "cdr");
    const auto paths = w.addChannel(w.addSchema("ddsnav::msg::Path", "omgidl", ""), "planning/path", "cdr");
    std::uint64_t t = 1000;
    auto ask = [&](std::uint32_t id, const planner::Vec3& from, const std::string& reason) {
      msg::PlanRequest request;
      request.header().frame_id("map");
      request.request_id(id);
      request.start(nodes::toMsg(planner::State{from, 0.6}));
      request.goal(nodes::toMsg(planner::State{{35, 30, 0}, 0.0}));
      request.goal_radius(1.0);
      request.planner("gart-lazy");
      request.time_budget_s(1.0);
      request.reason(reason);
      w.write(requests, t, t, ddsnav::testing::cdrBytesOf(request));
      t += 1000;
    };
    auto answer = [&](std::uint32_t id, const std::vector<planner::Vec3>& points) {
      msg::Path path;
      path.header().frame_id("map");
      path.request_id(id);
      path.solved(true);
      for (const auto& p : points) path.states().push_back(nodes::toMsg(planner::State{p, 0.0}));
      w.write(paths, t, t, ddsnav::testing::cdrBytesOf(path));
      t += 1000;
    };
    ask(1, {2, 2, 0}, "start");
    answer(1, {{2, 2, 0}, {20, 5, 0}, {35, 30, 0}});
    ask(2, {8, 3, 0}, "shorter_route: 20 s left");
    answer(2, {{8, 3, 0}, {35, 30, 0}});  // not flown: not the guide
    ask(3, {10, 3.3, 0}, "trajectory_blocked: trajectory sample at t=3 s (20, 5) is no longer collision free");
    w.close();
    recording_ = file;
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string command(const std::string& extra = "") const {
    return std::string(DDSNAV_BIN_DIR) + "/ddsnav-replan-replay --recording " + recording_ + " --scenario " + (dir_ / "world.yaml").string() +
           " --seeds 3 " + extra;
  }

  fs::path dir_;
  std::string recording_;
};

TEST_F(ReplanReplay, SearchesTheBlockedReplanAgainGuidedByTheFlownPath) {
  const auto r = ddsnav::testing::runTool(command());
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("1 request(s) with reason 'trajectory_blocked'"), std::string::npos) << r.out;
  // The first plan's path (3 corners), from (10, 3.3) on: 10 m of its first edge and its 29.2 m second one, 0.5 m apart.
  EXPECT_NE(r.out.find("request 3 (trajectory_blocked"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("guide points of a 3-corner path"), std::string::npos) << "not the shorter route's 2-corner answer\n" << r.out;
  EXPECT_NE(r.out.find("unsolved 0 of 3"), std::string::npos) << r.out;
}

TEST_F(ReplanReplay, ReplaysEveryReasonWhenAskedTo) {
  const auto r = ddsnav::testing::runTool(command("--reason ''"));
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("3 request(s)"), std::string::npos) << r.out;
}

TEST_F(ReplanReplay, NamesAMissingRecording) {
  const auto r = ddsnav::testing::runTool(std::string(DDSNAV_BIN_DIR) + "/ddsnav-replan-replay --recording " + (dir_ / "none.mcap").string() + " --scenario " +
                     (dir_ / "world.yaml").string());
  EXPECT_NE(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("none.mcap"), std::string::npos) << r.out;
}

}  // namespace
