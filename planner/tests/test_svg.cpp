// The SVG renderer draws every obstacle, the tree and the path, and a side view in 3-D.
#include "ddsnav/planner/scenario.hpp"
#include "ddsnav/planner/svg.hpp"

#include <gtest/gtest.h>

#include <string>

namespace ddsnav::planner {
namespace {

int count(const std::string& text, const std::string& what) {
  int n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

TEST(Svg, TwoDimensionalWorldTreeAndPath) {
  const Scenario s = parseScenario(
      "dimensions: 2\nbounds: {min: [0, 0], max: [40, 20]}\nstart: [1, 1]\ngoal: [39, 19]\ngoal_radius: 1\n"
      "obstacles:\n  - {type: box, center: [10, 10], size: [4, 2], yaw: 0.5}\n  - {type: sphere, center: [20, 5], radius: 2}\n"
      "  - {type: ellipsoid, center: [30, 10], semi_axes: [3, 1], yaw: 1}\n");
  SvgScene scene;
  scene.scenario = &s;
  scene.tree = {{Vec3(1, 1, 0), Vec3(5, 5, 0)}, {Vec3(5, 5, 0), Vec3(39, 19, 0)}};
  scene.path = {State{Vec3(1, 1, 0), 0.0}, State{Vec3(5, 5, 0), 0.7}, State{Vec3(39, 19, 0), 0.4}};
  scene.title = "a <b> & c";
  const std::string svg = renderSvg(scene, 800);
  EXPECT_EQ(svg.rfind("<svg", 0), 0u);
  EXPECT_NE(svg.find("a &lt;b&gt; &amp; c"), std::string::npos);
  EXPECT_EQ(count(svg, "class='obs'"), 3);
  EXPECT_NE(svg.find("rotate("), std::string::npos);  // the yawed box and ellipse
  EXPECT_EQ(count(svg, "class='path'"), 1);
  EXPECT_EQ(count(svg, "class='tree'"), 1);
  EXPECT_EQ(count(svg, "class='goal'"), 1);
  // 800 px wide, 40 x 20 m world, 10 px margins and a 24 px title row: scale (800 - 20) / 40 = 19.5 px/m,
  // so the start (1, 1) sits at x = 10 + 19.5 = 29.5 and y = 10 + 24 + (20 - 1) * 19.5 = 404.5.
  EXPECT_NE(svg.find("cx='29.5' cy='404.5' r='4' class='start'"), std::string::npos);
}

TEST(Svg, ThreeDimensionalWorldHasTopAndSideViews) {
  const Scenario s = parseScenario(
      "dimensions: 3\nbounds: {min: [0, 0, 0], max: [100, 100, 50]}\nstart: [5, 5, 5]\ngoal: [95, 95, 5]\ngoal_radius: 2\n"
      "obstacles:\n  - {type: hill, center: [50, 50], height: 30, sigma: 10}\n");
  SvgScene scene;
  scene.scenario = &s;
  const std::string svg = renderSvg(scene);
  EXPECT_EQ(count(svg, "class='bounds'"), 2);  // top view and side view
  EXPECT_EQ(count(svg, "class='hill'"), 3);    // three contour circles on top
  EXPECT_EQ(count(svg, "<polygon class='obs'"), 1);  // the hill's profile on the side
  EXPECT_THROW(renderSvg(SvgScene{}), std::invalid_argument);
  EXPECT_THROW(writeSvg("/nonexistent-dir/x.svg", scene), std::runtime_error);
}

}  // namespace
}  // namespace ddsnav::planner
