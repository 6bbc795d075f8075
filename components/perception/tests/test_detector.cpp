#include "ddsnav/perception/chi_square.hpp"
#include "ddsnav/perception/obstacle_detector.hpp"
#include "ddsnav/perception/obstacle_tracker.hpp"
#include "ddsnav/sim/range_sensor.hpp"
#include "ddsnav/sim/ray_primitives.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <numeric>
#include <random>

namespace ddsnav::perception {
namespace {

using planner::Obstacle;
using planner::ObstacleType;

Obstacle box(Eigen::Vector3d c, Eigen::Vector3d size, double yaw) {
  Obstacle o;
  o.type = ObstacleType::Box;
  o.center = c;
  o.size = size;
  o.yaw = yaw;
  return o;
}
Obstacle sphere(Eigen::Vector3d c, double r) {
  Obstacle o;
  o.type = ObstacleType::Sphere;
  o.center = c;
  o.radius = r;
  return o;
}
Obstacle ellipsoid(Eigen::Vector3d c, Eigen::Vector3d a, double yaw) {
  Obstacle o;
  o.type = ObstacleType::Ellipsoid;
  o.center = c;
  o.semi_axes = a;
  o.yaw = yaw;
  return o;
}

// Obstacles spread around the sensor at the origin, none occluding another.
planner::Scenario scatteredWorld(int dimensions) {
  planner::Scenario s;
  s.name = "scattered";
  s.dimensions = dimensions;
  s.bounds_min = {-30, -30, 0};
  s.bounds_max = {30, 30, dimensions == 3 ? 20.0 : 0.0};
  const double z = dimensions == 3 ? 1.0 : 0.0;
  s.obstacles = {box({8, 0, z}, {2, 3, 2}, 0.6),  // no face at grazing incidence (see sensorFor)
                 sphere({0, 9, z}, 1.5),
                 ellipsoid({-10, 1, z}, {3, 1, 1}, 0.5),
                 box({3, -12, z}, {4, 1, 2}, -0.2),
                 sphere({-7, -7, z}, 1.0),
                 ellipsoid({14, 10, z}, {1.5, 1.5, 1}, 0.0)};
  return s;
}

sim::RangeSensorConfig sensorFor(int dimensions, double sigma, std::uint64_t seed) {
  // 64 rings (0.63 deg apart): with 32 (1.1 deg) the rings on a grazing box face 10 m away are
  // more than the 0.4 m tolerance apart and the face is a separate Euclidean cluster.
  auto c = dimensions == 3 ? sim::RangeSensorConfig::lidar3d(64, 1024, -25, 15, 40)
                           : sim::RangeSensorConfig::scanner2d(720, 40);
  c.walls = false;
  c.floor = true;
  c.range_noise_sigma = sigma;
  c.seed = seed;
  return c;
}

// `whole`: one ellipse per obstacle part (no length cut), for the tests that count obstacles.
DetectorParams paramsFor(int dimensions, double sigma, bool whole = false) {
  DetectorParams p;
  if (whole) p.max_segment_length = 0.0;
  p.range_noise_sigma = sigma;
  p.beam_spacing = 2 * std::numbers::pi / (dimensions == 3 ? 1024 : 720);
  return p;
}

Eigen::Vector3d sensorAt(int dimensions) { return {0, 0, dimensions == 3 ? 1.5 : 0.0}; }

class DetectorScenes : public ::testing::TestWithParam<int> {};

TEST_P(DetectorScenes, OneEllipsoidPerObstacleInView) {
  const int dims = GetParam();
  const auto world = scatteredWorld(dims);
  sim::RangeSensor sensor(world, sensorFor(dims, 0.02, 1));
  const auto cloud = sensor.scan({sensorAt(dims), 0.0});
  ObstacleDetector detector(paramsFor(dims, 0.02, /*whole=*/true));
  const auto obstacles = detector.detect(cloud.points, cloud.origin);
  ASSERT_EQ(obstacles.size(), world.obstacles.size());
  // Each obstacle has exactly one ellipsoid whose centre is within the obstacle's extent.
  for (const auto& o : world.obstacles) {
    int near = 0;
    for (const auto& e : obstacles) {
      EXPECT_EQ(e.dimensions, dims);
      Eigen::Vector3d d = e.center - o.center;
      if (dims == 2) d.z() = 0;
      near += d.head<2>().norm() < 3.0;
    }
    EXPECT_EQ(near, 1) << "obstacle at " << o.center.transpose();
  }
  if (dims == 2) {
    for (const auto& e : obstacles) EXPECT_EQ(e.semi_axes.z(), 0.0);
  }
}

// Monte Carlo over the sensor noise: in every noisy scan, at least p of the true surface points its
// beams hit (the noise-free returns, above the ground threshold) lie inside their obstacle's ellipsoid.
// Checked for whole obstacles and for the default pieces (then a true point belongs to the piece
// whose centre is nearest).
TEST_P(DetectorScenes, EllipsoidsHoldTheTrueSurfaceWithProbabilityP) {
  for (const bool whole : {true, false}) {
  SCOPED_TRACE(whole ? "whole obstacles" : "pieces");
  const int dims = GetParam();
  const auto world = scatteredWorld(dims);
  const DetectorParams params = paramsFor(dims, 0.03, whole);
  ObstacleDetector detector(params);
  sim::RangeSensor sensor(world, sensorFor(dims, 0.03, 11));
  long inside = 0, total = 0;
  for (int trial = 0; trial < (dims == 3 ? 4 : 20); ++trial) {
    const auto cloud = sensor.scan({sensorAt(dims), 0.0});
    const auto obstacles = detector.detect(cloud.points, cloud.origin);
    if (whole) {
      ASSERT_EQ(obstacles.size(), world.obstacles.size());
    } else {
      ASSERT_GT(obstacles.size(), world.obstacles.size());  // the 6 m ellipse and the 4 m box are cut
    }
    const auto& ranges = sensor.lastRanges();
    for (size_t i = 0; i < ranges.size(); ++i) {
      if (ranges[i] == sim::kNoHit) continue;
      const int columns = sensor.config().columns;
      const Eigen::Vector3d p = cloud.origin + ranges[i] * sensor.beamDirection(static_cast<int>(i) / columns,
                                                                                 static_cast<int>(i) % columns);
      if (dims == 3 && p.z() <= params.ground_z) continue;
      // The obstacle a true point belongs to: the ellipsoid whose centre is nearest.
      const ObstacleEllipsoid* owner = nullptr;
      double best = std::numeric_limits<double>::infinity();
      for (const auto& e : obstacles) {
        Eigen::Vector3d diff = e.center - p;
        if (dims == 2) diff.z() = 0.0;
        if (diff.norm() < best) best = diff.norm(), owner = &e;
      }
      ++total;
      inside += owner->contains(p);
    }
  }
  const double p = params.probability;
  const double fraction = static_cast<double>(inside) / total;
  const double sampling_error = 3.0 * std::sqrt(p * (1 - p) / total);
  EXPECT_GT(total, 1000);
  EXPECT_GE(fraction, p - sampling_error) << inside << " of " << total;
  std::printf("%dD %s: %.4f of %ld true surface points inside\n", dims, whole ? "whole" : "pieces", fraction, total);
  }
}

TEST_P(DetectorScenes, GaussianSamplesFallInsideWithProbabilityP) {
  // The ellipsoid is the p-level set of the fitted Gaussian: samples of N(centre, covariance) land
  // inside it with probability p (checks the quantile, the eigen decomposition and `contains`).
  const int dims = GetParam();
  const auto world = scatteredWorld(dims);
  sim::RangeSensor sensor(world, sensorFor(dims, 0.02, 3));
  const auto cloud = sensor.scan({sensorAt(dims), 0.0});
  ObstacleDetector detector(paramsFor(dims, 0.02));
  const auto obstacles = detector.detect(cloud.points, cloud.origin);
  ASSERT_FALSE(obstacles.empty());
  std::mt19937_64 rng(9);
  std::normal_distribution<double> normal;
  const int samples = 5000;
  for (const auto& e : obstacles) {
    int inside = 0;
    const double q = chiSquareQuantile(e.probability, dims);
    for (int i = 0; i < samples; ++i) {
      // x = centre + axes * diag(semi / sqrt(q)) * z
      Eigen::Vector3d z(normal(rng), normal(rng), dims == 3 ? normal(rng) : 0.0);
      const Eigen::Vector3d x = e.center + e.axes * (e.semi_axes.cwiseProduct(z) / std::sqrt(q));
      inside += e.mahalanobis2(x) <= q;
    }
    const double p = e.probability;
    EXPECT_NEAR(static_cast<double>(inside) / samples, p, 4.0 * std::sqrt(p * (1 - p) / samples));
    EXPECT_NEAR(e.axes.determinant(), 1.0, 1e-9);
    EXPECT_TRUE(e.orientation.toRotationMatrix().isApprox(e.axes, 1e-9));
  }
}

INSTANTIATE_TEST_SUITE_P(TwoAndThreeD, DetectorScenes, ::testing::Values(2, 3));

TEST(Detector, GroundIsRemovedIn3D) {
  planner::Scenario empty = scatteredWorld(3);
  empty.obstacles.clear();
  sim::RangeSensor sensor(empty, sensorFor(3, 0.02, 1));
  const auto cloud = sensor.scan({{0, 0, 1.5}, 0.0});
  ASSERT_GT(cloud.points.size(), 1000u);
  ObstacleDetector detector(paramsFor(3, 0.02));
  EXPECT_TRUE(detector.detect(cloud.points, cloud.origin).empty());
  EXPECT_GT(detector.stats().ground_voxels, 100u);
}

TEST(Detector, SeeThroughGapSplitsACluster) {
  // Two boxes side by side with a 0.25 m gap, 8 m ahead: one Euclidean cluster (gap < 0.4 m), but
  // the scanner's beams pass through the gap, so they are two obstacles.
  planner::Scenario s = scatteredWorld(2);
  s.obstacles = {box({8, -1.125, 0}, {1, 2, 0}, 0.0), box({8, 1.125, 0}, {1, 2, 0}, 0.0)};
  sim::RangeSensor sensor(s, sensorFor(2, 0.0, 1));
  const auto cloud = sensor.scan({{0, 0, 0}, 0.0});
  DetectorParams params = paramsFor(2, 0.0, /*whole=*/true);
  params.gap_min_width = 0.15;
  ObstacleDetector detector(params);
  EXPECT_EQ(detector.detect(cloud.points, cloud.origin).size(), 2u);
  EXPECT_EQ(detector.stats().clusters, 1u);
  params.split_gaps = false;
  ObstacleDetector unsplit(params);
  EXPECT_EQ(unsplit.detect(cloud.points, cloud.origin).size(), 1u);
}

TEST(Detector, BadCloudsNeverCrash) {
  ObstacleDetector detector(DetectorParams{});
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  const Eigen::Vector3d origin(0, 0, 1);
  EXPECT_TRUE(detector.detect({}, origin).empty());
  std::vector<Eigen::Vector3f> bad = {{nan, 0, 0}, {inf, 1, 1}, {1, -inf, 2}, {nan, nan, nan}, {1e30f, 0, 1},
                                      {-3e38f, 3e38f, 3e38f}};
  EXPECT_TRUE(detector.detect(bad, origin).empty());
  EXPECT_EQ(detector.stats().dropped_invalid, bad.size());
  // A real obstacle among garbage is still found.
  for (int i = 0; i < 50; ++i) bad.emplace_back(5.0f, -0.5f + 0.02f * i, 1.0f);
  EXPECT_EQ(detector.detect(bad, origin).size(), 1u);
  // Identical points, a single point.
  std::vector<Eigen::Vector3f> same(1000, Eigen::Vector3f(2, 2, 2));
  const auto one = detector.detect(same, origin);
  EXPECT_TRUE(one.empty());  // one voxel is below min_cluster_size
  EXPECT_THROW(detector.detect(same, Eigen::Vector3d(std::nan(""), 0, 0)), std::invalid_argument);
  DetectorParams small;
  small.max_points = 10;
  ObstacleDetector limited(small);
  EXPECT_THROW(limited.detect(same, origin), std::invalid_argument);
}

TEST(Detector, HugeCloudIsProcessed) {
  // 3 million points: a dense random slab around the sensor, ~700k voxels, one connected mass.
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(-10.f, 10.f), h(0.2f, 2.f);
  std::vector<Eigen::Vector3f> points;
  points.reserve(3'000'000);
  for (int i = 0; i < 3'000'000; ++i) points.emplace_back(u(rng), u(rng), h(rng));
  DetectorParams params;
  params.max_segment_length = 0.0;  // one piece, so the mass is one obstacle
  params.max_cluster_size = 2'000'000;
  ObstacleDetector detector(params);
  const auto obstacles = detector.detect(points, Eigen::Vector3d(0, 0, 1));
  EXPECT_EQ(detector.stats().input_points, 3'000'000u);
  EXPECT_GT(detector.stats().voxels, 600'000u);
  EXPECT_EQ(detector.stats().clusters, 1u);
  ASSERT_EQ(obstacles.size(), 1u);  // it surrounds the sensor: no azimuth gap to split at
  EXPECT_NEAR(obstacles[0].center.x(), 0.0, 0.1);
  params.max_cluster_size = 100'000;  // the same mass is now too big to be a cluster
  ObstacleDetector capped(params);
  EXPECT_TRUE(capped.detect(points, Eigen::Vector3d(0, 0, 1)).empty());
}

TEST(Detector, RejectsBadParameters) {
  DetectorParams p;
  p.probability = 1.0;
  EXPECT_THROW(ObstacleDetector{p}, std::invalid_argument);
  p = {};
  p.voxel_size = -0.1;
  EXPECT_THROW(ObstacleDetector{p}, std::invalid_argument);
  p = {};
  p.max_cluster_size = 0;
  EXPECT_THROW(ObstacleDetector{p}, std::invalid_argument);
  p = {};
  p.cluster_tolerance = std::nan("");
  EXPECT_THROW(ObstacleDetector{p}, std::invalid_argument);
  p = {};
  p.max_segment_length = -1.0;
  EXPECT_THROW(ObstacleDetector{p}, std::invalid_argument);
}

TEST(Detector, LongWallBecomesAChainOfBoundedPieces) {
  // A 22 m wall 3 m from the scanner: one cluster, cut into pieces no longer than
  // max_segment_length, whose ellipses stay within a metre of the wall line.
  planner::Scenario s = scatteredWorld(2);
  s.obstacles = {box({3.5, 0, 0}, {1, 22, 0}, 0.0)};
  sim::RangeSensor sensor(s, sensorFor(2, 0.02, 1));
  const auto cloud = sensor.scan({{0, 0, 0}, 0.0});
  DetectorParams params = paramsFor(2, 0.02);
  ObstacleDetector detector(params);
  const auto pieces = detector.detect(cloud.points, cloud.origin);
  EXPECT_EQ(detector.stats().clusters, 1u);
  ASSERT_GE(pieces.size(), 10u);
  std::size_t supported = 0;
  for (const auto& e : pieces) {
    float lo = 1e9f, hi = -1e9f;
    for (const auto& sp : e.support) lo = std::min(lo, sp.position.y()), hi = std::max(hi, sp.position.y());
    EXPECT_LE(hi - lo, params.max_segment_length + 1e-4);
    EXPECT_LT(e.semi_axes.x(), params.max_segment_length);    // the whole wall would give ~19 m
    EXPECT_NEAR(e.center.x(), 3.0, 0.1);
    EXPECT_LT(e.semi_axes.y(), 0.3);
    supported += e.support.size();
  }
  EXPECT_EQ(supported, detector.stats().clustered_points);  // no voxel lost by the cut
}

}  // namespace
}  // namespace ddsnav::perception

namespace ddsnav::perception {
namespace {

TEST(Detector, WithoutTheFitDetectionsCarryTheSameVoxelsAndTrackTheSame) {
  // fit_detections = false (the perception component): the same pieces with the same voxels and bearings,
  // no ellipse, the voxels' mean as centre; a tracker fed either gives the same tracks.
  for (int dimensions : {2, 3}) {
    SCOPED_TRACE(dimensions);
    const planner::Scenario world = scatteredWorld(dimensions);
    sim::RangeSensor sensor(world, sensorFor(dimensions, 0.02, 3));
    DetectorParams params = paramsFor(dimensions, 0.02);
    ObstacleDetector fitted(params);
    params.fit_detections = false;
    ObstacleDetector unfitted(params);
    ObstacleTracker from_fitted(TrackerParams::matching(params)), from_unfitted(TrackerParams::matching(params));
    for (int step = 0; step < 4; ++step) {
      const auto cloud = sensor.scan({sensorAt(dimensions) + Eigen::Vector3d(0.5 * step, 0.2 * step, 0), 0.1 * step});
      const auto a = fitted.detect(cloud.points, cloud.origin);
      const auto b = unfitted.detect(cloud.points, cloud.origin);
      ASSERT_EQ(a.size(), b.size());
      ASSERT_FALSE(a.empty());
      for (std::size_t i = 0; i < a.size(); ++i) {
        ASSERT_EQ(a[i].support.size(), b[i].support.size());
        Eigen::Vector3d mean = Eigen::Vector3d::Zero();
        for (std::size_t k = 0; k < a[i].support.size(); ++k) {
          EXPECT_EQ(a[i].support[k].position, b[i].support[k].position);
          EXPECT_EQ(a[i].support[k].bearing, b[i].support[k].bearing);
          mean += b[i].support[k].position.cast<double>();
        }
        EXPECT_GT(a[i].semi_axes.x(), 0.0);
        EXPECT_EQ(b[i].semi_axes, Eigen::Vector3d::Zero());
        EXPECT_EQ(b[i].covariance, Eigen::Matrix3d::Zero());
        EXPECT_EQ(b[i].dimensions, a[i].dimensions);
        EXPECT_EQ(b[i].probability, a[i].probability);
        EXPECT_EQ(b[i].point_count, b[i].support.size());
        EXPECT_LT((b[i].center - mean / static_cast<double>(b[i].support.size())).norm(), 1e-9);
      }
      const auto& ta = from_fitted.update(a, cloud.origin);
      const auto& tb = from_unfitted.update(b, cloud.origin);
      ASSERT_EQ(ta.size(), tb.size());
      for (std::size_t i = 0; i < ta.size(); ++i) {
        EXPECT_EQ(ta[i].id, tb[i].id);
        EXPECT_EQ(ta[i].center, tb[i].center);
        EXPECT_EQ(ta[i].covariance, tb[i].covariance);
      }
    }
  }
}

TEST(Pieces, SplitByExtentBoundsEveryPieceAndKeepsEveryPoint) {
  // An L of two 5 m faces (0.1 m spacing): every piece fits the rule, no point is lost or doubled.
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i <= 50; ++i) points.emplace_back(0.1f * i, 0.0f, 0.0f);
  for (int i = 1; i <= 50; ++i) points.emplace_back(0.0f, 0.1f * i, 0.0f);
  const std::vector<int> all = [&] {
    std::vector<int> v(points.size());
    for (std::size_t i = 0; i < v.size(); ++i) v[i] = static_cast<int>(i);
    return v;
  }();
  Clusters pieces;
  splitByExtent(points, all, 2, 1.5, 0.4, pieces);
  ASSERT_GE(pieces.size(), 8u);
  std::vector<int> seen(points.size(), 0);
  for (std::size_t k = 0; k < pieces.size(); ++k) {
    const Eigen::Matrix3f axes = principalAxes(points, pieces[k], 2);
    Eigen::Vector3f lo = Eigen::Vector3f::Constant(1e9f), hi = -lo;
    for (int i : pieces[k]) {
      ++seen[static_cast<std::size_t>(i)];
      const Eigen::Vector3f q = axes.transpose() * points[static_cast<std::size_t>(i)];
      lo = lo.cwiseMin(q), hi = hi.cwiseMax(q);
    }
    EXPECT_FALSE(pieceTooBig(hi - lo, 2, 1.5f, 0.4f)) << "piece " << k << " extent " << (hi - lo).transpose();
  }
  for (int count : seen) EXPECT_EQ(count, 1);
  Clusters whole;
  splitByExtent(points, all, 2, 0.0, 0.0, whole);  // 0: never cut
  EXPECT_EQ(whole.size(), 1u);
}

TEST(Pieces, OneCornerVoxelMakesAThinPieceThickerNotLonger) {
  // A 1.4 m face plus one voxel of the adjoining face 0.3 m off its end: the per-axis enclosing
  // grows the short axis to hold it; the long axis stays near the Gaussian value (0.88 x 1.4 m).
  std::vector<SupportPoint> support;
  for (int i = 0; i <= 14; ++i) support.push_back({Eigen::Vector3f(0, 0.1f * i, 0), Eigen::Vector3f(1, 0, 0)});
  EllipsoidFitParams params{0.99, 0.02, 0.1, true};
  params.shorten_to_points = false;  // the Gaussian bound, the enclosing step alone
  const ObstacleEllipsoid face = fitEllipsoid(support, 2, params);
  support.push_back({Eigen::Vector3f(0.3f, 1.4f, 0), Eigen::Vector3f(1, 0, 0)});
  const ObstacleEllipsoid corner = fitEllipsoid(support, 2, params);
  for (const auto& s : support) EXPECT_TRUE(corner.contains(s.position.cast<double>()));
  EXPECT_LT(corner.semi_axes.x(), 1.25 * face.semi_axes.x());  // uniform scaling made it ~3x
  EXPECT_GT(corner.semi_axes.y(), 2.0 * face.semi_axes.y());
  // Shortened to its points (the default), neither is longer, and every point stays inside.
  params.shorten_to_points = true;
  const ObstacleEllipsoid short_corner = fitEllipsoid(support, 2, params);
  for (const auto& s : support) EXPECT_TRUE(short_corner.contains(s.position.cast<double>()));
  EXPECT_LE(short_corner.semi_axes.x(), corner.semi_axes.x() + 1e-9);
}

// An inner corner seen from the corridor turning around it (stunnel_0.5): a 1.2 m face and a 0.3 m leg of the
// adjoining face. Kept whole (thinner than 0.4 m), its ellipse reached 0.9 m past the corner into the corridor and
// closed it for a 1 m robot; the default width (0.25 m) cuts it into nearly straight pieces, none of which reaches
// much past the corner.
static double reachPastTheCorner(double max_width) {
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i <= 12; ++i) points.emplace_back(0.0f, 0.1f * i, 0.0f);
  for (int i = 1; i <= 3; ++i) points.emplace_back(-0.1f * i, 1.2f, 0.0f);
  std::vector<int> all(points.size());
  std::iota(all.begin(), all.end(), 0);
  Clusters pieces;
  splitByExtent(points, all, 2, 1.5, max_width, pieces);
  const EllipsoidFitParams params{0.99, 0.02, 0.1, true};
  double reach = -std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < pieces.size(); ++k) {
    const ObstacleEllipsoid e = fitEllipsoid(points, pieces[k], Eigen::Vector3d(1.0, 1.5, 0.0), 2, params);
    for (int i : pieces[k]) EXPECT_TRUE(e.contains(points[static_cast<std::size_t>(i)].cast<double>()));
    reach = std::max(reach, e.center.y() + std::sqrt(chiSquareQuantile(0.99, 2) * e.covariance(1, 1)) - 1.2);
  }
  return reach;
}

TEST(Pieces, AnInnerCornerIsCutSoItsPiecesEndNearTheCorner) {
  EXPECT_GT(reachPastTheCorner(0.4), 0.6);  // as before: one piece, its bound far past the corner
  EXPECT_LT(reachPastTheCorner(DetectorParams{}.max_segment_width), 0.4);
}

TEST(Pieces, AWallPieceEndsAboutWhereItsPointsEnd) {
  // A 1.5 m piece of wall: the Gaussian p-bound reaches 0.88 x 1.5 = 1.31 m from its centre, 0.56 m past its
  // last point; shortened, the ellipse ends two enclosing margins (2 x 0.13 m) past it, and holds every point
  // pushed out by one margin.
  std::vector<SupportPoint> support;
  for (int i = 0; i <= 15; ++i) support.push_back({Eigen::Vector3f(0.1f * i, 0, 0), Eigen::Vector3f(0, 1, 0)});
  EllipsoidFitParams params{0.99, 0.02, 0.1, true};
  const double margin = enclosingMargin(params.range_noise_sigma, params.voxel_size, 2);
  params.shorten_to_points = false;
  const ObstacleEllipsoid gaussian = fitEllipsoid(support, 2, params);
  params.shorten_to_points = true;
  const ObstacleEllipsoid piece = fitEllipsoid(support, 2, params);
  EXPECT_GT(gaussian.semi_axes.x(), 0.88 * 1.5 - 0.01);  // 16 discrete points: 1.40
  EXPECT_NEAR(piece.semi_axes.x(), 0.75 + 2 * margin, 0.02);
  EXPECT_NEAR(piece.semi_axes.y(), gaussian.semi_axes.y(), 1e-9);  // only the length changes
  EXPECT_NEAR(piece.center.x(), 0.75, 1e-6);
  for (const auto& s : support) {
    const Eigen::Vector3d p = s.position.cast<double>();
    const Eigen::Vector3d d = p - piece.center;
    EXPECT_TRUE(piece.contains(p + (d.norm() > 0 ? Eigen::Vector3d(d * (margin / d.norm())) : Eigen::Vector3d::Zero())));
  }
}

}  // namespace
}  // namespace ddsnav::perception
