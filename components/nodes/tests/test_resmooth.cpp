// ddsnav resmooth on a small recording written here: a request and its answer on a 2-D world with nothing mapped
// yet. Runs the binary (no DDS).
#include "ddsnav/nodes/convert.hpp"
#include "run_tool.hpp"

#include <ddsnav/msg/messages.hpp>
#include <ddsnav/record/mcap.hpp>

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace {

using namespace ddsnav;
namespace fs = std::filesystem;

class Resmooth : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("ddsnav-resmooth-" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    std::ofstream(dir_ / "world.yaml") << ddsnav::testing::kOpenYard2d;
  }
  void TearDown() override { fs::remove_all(dir_); }

  // A recording of request 4 and its answer through `points`.
  std::string record(const std::vector<planner::Vec3>& points) {
    const std::string file = (dir_ / "run.mcap").string();
    record::McapWriter w(file);
    const auto request_channel = w.addChannel(w.addSchema("ddsnav::msg::PlanRequest", "omgidl", ""), "planning/request", "cdr");
    const auto path_channel = w.addChannel(w.addSchema("ddsnav::msg::Path", "omgidl", ""), "planning/path", "cdr");
    msg::PlanRequest request;
    request.request_id(4);
    request.start(nodes::toMsg(planner::State{points.front(), 0.0}));
    request.reason("start");
    w.write(request_channel, 1000, 1000, ddsnav::testing::cdrBytesOf(request));
    msg::Path path;
    path.request_id(4);
    path.solved(true);
    for (const auto& p : points) path.states().push_back(nodes::toMsg(planner::State{p, 0.0}));
    w.write(path_channel, 2000, 2000, ddsnav::testing::cdrBytesOf(path));
    w.close();
    return file;
  }

  std::string command(const std::string& recording, int request) const {
    return std::string(DDSNAV_BIN_DIR) + "/ddsnav-resmooth --recording " + recording + " --scenario " + (dir_ / "world.yaml").string() +
           " --request " + std::to_string(request);
  }

  fs::path dir_;
};

TEST_F(Resmooth, SmoothsTheRecordedAnswerAgain) {
  const auto r = ddsnav::testing::runTool(command(record({{2, 2, 0}, {20, 5, 0}, {35, 30, 0}}), 4));
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("no map before the answer"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("plain world: smoothed"), std::string::npos) << r.out;
}

TEST_F(Resmooth, SaysWhyTheSmootherRefusedIt) {
  const auto r = ddsnav::testing::runTool(command(record({{2, 2, 0}, {20, 5, 0}, {45, 30, 0}}), 4));  // the last state lies outside the bounds
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("plain world: refused: smoother: path state 2 (45, 30) is in collision or out of bounds"), std::string::npos) << r.out;
}

TEST_F(Resmooth, NamesARequestTheRecordingDoesNotAnswer) {
  const auto r = ddsnav::testing::runTool(command(record({{2, 2, 0}, {35, 30, 0}}), 9));
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("no planning/path answers request 9"), std::string::npos) << r.out;
}

}  // namespace
