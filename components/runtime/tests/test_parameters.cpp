// Parameter descriptors (range checks where the value enters, the --describe table) and the stock topic
// table (the one docs/architecture.md shows).
#include <ddsnav/runtime/component.hpp>
#include <ddsnav/runtime/parameters.hpp>
#include <ddsnav/runtime/topics.hpp>

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

namespace ddsnav::runtime {
namespace {

template <class F>
std::string errorOf(F&& f) {
  try {
    f();
  } catch (const ParameterError& e) {
    return e.what();
  }
  return "";
}

TEST(ParameterDescriptors, RangeIsCheckedWhereTheValueEnters) {
  auto p = Parameters::load("", {"rate_hz=150", "count=0", "mode=fast", "gain=0"});
  const std::string rate = errorOf([&] { p.declare<double>("rate_hz", 10.0, {.min = 0, .max = 100, .unit = "Hz", .doc = "r"}); });
  EXPECT_EQ(rate, "parameter 'rate_hz' (from --param): expected [0, 100] Hz, got 150");
  const std::string count = errorOf([&] { p.declare<std::int64_t>("count", 3, {.min = 1, .doc = "c"}); });
  EXPECT_EQ(count, "parameter 'count' (from --param): expected >= 1, got 0");
  const std::string mode = errorOf([&] { p.declare<std::string>("mode", "slow", {.choices = {"slow", "exact"}}); });
  EXPECT_EQ(mode, "parameter 'mode' (from --param): expected one of: slow, exact, got 'fast'");
  const std::string gain = errorOf([&] { p.declare<double>("gain", 1.0, {.above = 0, .below = 1}); });
  EXPECT_EQ(gain, "parameter 'gain' (from --param): expected (0, 1), got 0");
  // A value inside the range passes; a default is not checked against a given value's source.
  auto q = Parameters::load("", {"rate_hz=100"});
  EXPECT_EQ(q.declare<double>("rate_hz", 10.0, {.min = 0, .max = 100}), 100.0);
  EXPECT_EQ(q.declare<double>("other", 0.5, {.above = 0}), 0.5);
}

TEST(ParameterDescriptors, DescribeListsDefaultRangeUnitAndDoc) {
  auto p = Parameters::describing();
  p.declare<double>("rate_hz", 10.0, {.above = 0, .max = 100, .unit = "Hz", .doc = "how often"});
  p.require<std::string>("scenario", ParamSpec{.doc = "scenario file"});
  p.declareOptional<bool>("kinodynamic", {.doc = "default: whether the scenario has a vehicle"});
  p.declare<std::vector<std::string>>("options", {}, {.doc = "a | b"});
  EXPECT_EQ(p.describeTable(),
            "| parameter | type | default | range | unit | description |\n|---|---|---|---|---|---|\n"
            "| `rate_hz` | number | 10 | (0, 100] | Hz | how often |\n"
            "| `scenario` | string | (required) |  |  | scenario file |\n"
            "| `kinodynamic` | bool | (see description) |  |  | default: whether the scenario has a vehicle |\n"
            "| `options` | list | [] |  |  | a / b |\n");
}

TEST(ParameterDescriptors, RuntimeParametersAreBoundedByTheirDescriptors) {
  auto p = Parameters::load("", {"heartbeat_period_s=inf"});
  EXPECT_NE(errorOf([&] { RuntimeParams r(p); }).find("heartbeat_period_s"), std::string::npos);
  auto q = Parameters::load("", {"heartbeat_period_s=61"});
  EXPECT_EQ(errorOf([&] { RuntimeParams r(q); }), "parameter 'heartbeat_period_s' (from --param): expected (0, 60] s, got 61");
  auto c = Parameters::load("", {"clock=wall"});
  EXPECT_EQ(errorOf([&] { RuntimeParams r(c); }), "parameter 'clock' (from --param): expected one of: system, topic, got 'wall'");
}

TEST(StockTopics, NamespacedNamesFindTheirRow) {
  ASSERT_NE(findStockTopic("uav1/sensors/points"), nullptr);
  EXPECT_EQ(findStockTopic("uav1/sensors/points")->profile, "sensorData");
  EXPECT_EQ(findStockTopic("planning/path")->type, "Path");
  EXPECT_EQ(findStockTopic("xsensors/points"), nullptr);
  EXPECT_EQ(findStockTopic("unknown/topic"), nullptr);
}

TEST(StockTopics, DocsArchitectureTableIsTheStockTable) {
  std::ifstream in(std::string(DDSNAV_SOURCE_DIR) + "/docs/architecture.md");
  ASSERT_TRUE(in) << "docs/architecture.md not found";
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_NE(text.str().find(topicTable()), std::string::npos)
      << "docs/architecture.md must hold the table of components/runtime/src/topics.cpp exactly:\n" << topicTable();
}

}  // namespace
}  // namespace ddsnav::runtime
