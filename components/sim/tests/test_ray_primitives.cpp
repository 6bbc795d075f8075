// Hand-computed ray / primitive intersections for every obstacle type.
#include "ddsnav/sim/ray_primitives.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace ddsnav::sim {
namespace {

using Eigen::Vector3d;
constexpr double kPi = std::numbers::pi;

Ray makeRay(Vector3d origin, Vector3d direction) { return {origin, direction.normalized()}; }

TEST(RayBox, AxisAlignedFrontFace) {
  EXPECT_NEAR(intersectBox(makeRay({0, 0, 0}, {1, 0, 0}), {5, 0, 0}, {2, 2, 2}, 0.0, false), 4.0, 1e-12);
}

TEST(RayBox, RotatedBoxPresentsItsCorner) {
  // Yawed 45 deg, the corner of a 2x2 box points at the origin: it is sqrt(2) closer than the centre.
  EXPECT_NEAR(intersectBox(makeRay({0, 0, 0}, {1, 0, 0}), {5, 0, 0}, {2, 2, 2}, kPi / 4, false),
              5.0 - std::sqrt(2.0), 1e-12);
}

TEST(RayBox, DiagonalRayHitsTopFace) {
  // From (0,0,3) towards (4,0,1): the top face z = 1 of the box centred (5,0,0) is reached at x = 4.
  const Vector3d d = Vector3d(4, 0, -2).normalized();
  EXPECT_NEAR(intersectBox({{0, 0, 3}, d}, {5, 0, 0}, {2, 2, 2}, 0.0, false), std::sqrt(20.0), 1e-12);
}

TEST(RayBox, MissesAndInside) {
  EXPECT_EQ(intersectBox(makeRay({0, 0, 0}, {0, 1, 0}), {5, 0, 0}, {2, 2, 2}, 0.0, false), kNoHit);
  EXPECT_EQ(intersectBox(makeRay({0, 0, 0}, {-1, 0, 0}), {5, 0, 0}, {2, 2, 2}, 0.0, false), kNoHit);
  EXPECT_EQ(intersectBox(makeRay({5, 0, 0}, {1, 0, 0}), {5, 0, 0}, {2, 2, 2}, 0.0, false), 0.0);
  // Above the box in 3-D, but the planar footprint is hit.
  EXPECT_EQ(intersectBox(makeRay({0, 0, 5}, {1, 0, 0}), {5, 0, 0}, {2, 2, 2}, 0.0, false), kNoHit);
  EXPECT_NEAR(intersectBox(makeRay({0, 0, 5}, {1, 0, 0}), {5, 0, 0}, {2, 2, 0}, 0.0, true), 4.0, 1e-12);
}

TEST(RaySphere, CentralAndOffsetHits) {
  EXPECT_NEAR(intersectSphere(makeRay({0, 0, 0}, {1, 0, 0}), {10, 0, 0}, 2.0, false), 8.0, 1e-12);
  EXPECT_NEAR(intersectSphere(makeRay({0, 1, 0}, {1, 0, 0}), {10, 0, 0}, 2.0, false), 10.0 - std::sqrt(3.0), 1e-12);
  EXPECT_EQ(intersectSphere(makeRay({0, 3, 0}, {1, 0, 0}), {10, 0, 0}, 2.0, false), kNoHit);
  EXPECT_EQ(intersectSphere(makeRay({0, 0, 0}, {-1, 0, 0}), {10, 0, 0}, 2.0, false), kNoHit);
  EXPECT_EQ(intersectSphere(makeRay({10, 0, 0}, {1, 0, 0}), {10, 0, 0}, 2.0, false), 0.0);
}

TEST(RaySphere, PlanarCircleIgnoresZ) {
  EXPECT_NEAR(intersectSphere(makeRay({0, 0, 0}, {1, 0, 0}), {10, 0, 7}, 2.0, true), 8.0, 1e-12);
  EXPECT_EQ(intersectSphere(makeRay({0, 0, 0}, {1, 0, 0}), {10, 0, 7}, 2.0, false), kNoHit);
}

TEST(RayEllipsoid, AxisAlignedAndRotated) {
  EXPECT_NEAR(intersectEllipsoid(makeRay({0, 0, 0}, {1, 0, 0}), {10, 0, 0}, {3, 1, 1}, 0.0, false), 7.0, 1e-12);
  // Rotated by 90 deg the long axis lies along y: along x only the semi-axis 1 remains.
  EXPECT_NEAR(intersectEllipsoid(makeRay({0, 0, 0}, {1, 0, 0}), {10, 0, 0}, {3, 1, 1}, kPi / 2, false), 9.0, 1e-12);
  EXPECT_NEAR(intersectEllipsoid(makeRay({10, -10, 0}, {0, 1, 0}), {10, 0, 0}, {3, 1, 1}, kPi / 2, false), 7.0, 1e-12);
  // Vertical ray onto the top: z semi-axis 2.
  EXPECT_NEAR(intersectEllipsoid(makeRay({10, 0, 10}, {0, 0, -1}), {10, 0, 0}, {3, 1, 2}, 0.3, false), 8.0, 1e-12);
}

TEST(RayEllipsoid, ObliqueRayMatchesImplicitSurface) {
  // Yaw 30 deg, semi-axes (4, 2, 1): the hit must lie on the surface, and the ray just before it outside.
  const Vector3d c(3, -2, 1), a(4, 2, 1);
  const double yaw = kPi / 6;
  const Ray ray = makeRay({-8, 5, 3}, Vector3d(3, -2, 1) - Vector3d(-8, 5, 3) + Vector3d(0.5, 0.3, -0.2));
  const double t = intersectEllipsoid(ray, c, a, yaw, false);
  ASSERT_NE(t, kNoHit);
  auto implicit = [&](const Vector3d& p) {
    const Vector3d q = p - c;
    const double x = std::cos(yaw) * q.x() + std::sin(yaw) * q.y();
    const double y = -std::sin(yaw) * q.x() + std::cos(yaw) * q.y();
    return x * x / (a.x() * a.x()) + y * y / (a.y() * a.y()) + q.z() * q.z() / (a.z() * a.z());
  };
  EXPECT_NEAR(implicit(ray.origin + t * ray.direction), 1.0, 1e-9);
  EXPECT_GT(implicit(ray.origin + (t - 1e-3) * ray.direction), 1.0);
}

TEST(RayEllipsoid, PlanarEllipse) {
  EXPECT_NEAR(intersectEllipsoid(makeRay({0, 0, 0}, {1, 0, 0}), {10, 0, 0}, {3, 1, 0}, 0.0, true), 7.0, 1e-12);
}

TEST(RayHill, VerticalRayHitsPeak) {
  EXPECT_NEAR(intersectHill(makeRay({0, 0, 20}, {0, 0, -1}), {0, 0, 0}, 10.0, 5.0, 100.0), 10.0, 1e-5);
}

TEST(RayHill, HorizontalRayHitsHalfHeightContour) {
  // 10 exp(-x^2/50) = 5  ->  x = -sqrt(50 ln 2)
  EXPECT_NEAR(intersectHill(makeRay({-30, 0, 5}, {1, 0, 0}), {0, 0, 0}, 10.0, 5.0, 100.0),
              30.0 - std::sqrt(50.0 * std::log(2.0)), 1e-5);
}

TEST(RayHill, SlantedRayLandsOnSurfaceAndMissesAbove) {
  const Ray ray = makeRay({-20, 3, 12}, {1, 0.1, -0.4});
  const double t = intersectHill(ray, {2, 1, 0}, 10.0, 5.0, 100.0);
  ASSERT_NE(t, kNoHit);
  const Vector3d p = ray.origin + t * ray.direction;
  const double d2 = (p.x() - 2) * (p.x() - 2) + (p.y() - 1) * (p.y() - 1);
  EXPECT_NEAR(p.z(), 10.0 * std::exp(-d2 / 50.0), 1e-5);
  EXPECT_EQ(intersectHill(makeRay({-30, 0, 11}, {1, 0, 0}), {0, 0, 0}, 10.0, 5.0, 100.0), kNoHit);
  EXPECT_EQ(intersectHill(makeRay({-30, 0, 5}, {1, 0, 0}), {0, 0, 0}, 10.0, 5.0, 10.0), kNoHit);  // beyond t_max
}

// Lidar-like rays from beside a hill, against a fine brute-force march: the same first crossing (to the
// march's step) or the same miss, so the early rejection drops only rays that cannot hit. (Rays stay above
// z = 0.5 within t_max: below the 1 mm cut-off of the hill the brute force would find the ground.)
TEST(RayHill, AgreesWithABruteForceMarch) {
  const Vector3d centre(3, -2, 0);
  const double height = 20.0, sigma = 6.0, t_max = 50.0, step = 0.005;
  auto surfaceGap = [&](const Ray& r, double t) {
    const Vector3d p = r.origin + t * r.direction;
    const double d2 = (p.x() - centre.x()) * (p.x() - centre.x()) + (p.y() - centre.y()) * (p.y() - centre.y());
    return p.z() - height * std::exp(-d2 / (2 * sigma * sigma));
  };
  int hits = 0, misses = 0, mismatches = 0;
  for (int e = -6; e <= 15; e += 3)
    for (int a = 0; a < 360; a += 5) {
      const double el = e * kPi / 180, az = a * kPi / 180;
      const Ray r = makeRay({-15, -10, 6}, {std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el)});
      double brute = kNoHit;
      for (double t = 0; t <= t_max; t += step)
        if (surfaceGap(r, t) <= 0) {
          brute = t;
          break;
        }
      const double t = intersectHill(r, centre, height, sigma, t_max);
      (brute == kNoHit ? misses : hits)++;
      if ((brute == kNoHit) != (t == kNoHit) || (t != kNoHit && std::abs(t - brute) > 2 * step)) ++mismatches;
    }
  EXPECT_EQ(mismatches, 0);
  EXPECT_GT(hits, 50);
  EXPECT_GT(misses, 50);
}

TEST(RayBounds, ExitsThroughEnabledFaces) {
  const Vector3d lo(0, 0, 0), hi(10, 10, 10);
  EXPECT_NEAR(exitBounds(makeRay({1, 1, 1}, {1, 0, 0}), lo, hi, true, true, false, false), 9.0, 1e-12);
  EXPECT_NEAR(exitBounds(makeRay({1, 1, 1}, {0, 0, -1}), lo, hi, true, true, false, false), 1.0, 1e-12);
  EXPECT_EQ(exitBounds(makeRay({1, 1, 1}, {0, 0, 1}), lo, hi, true, true, false, false), kNoHit);
  EXPECT_NEAR(exitBounds(makeRay({1, 1, 1}, {0, 0, 1}), lo, hi, true, true, true, false), 9.0, 1e-12);
  EXPECT_EQ(exitBounds(makeRay({1, 1, 1}, {1, 0, 0}), lo, hi, false, true, false, false), kNoHit);
}

}  // namespace
}  // namespace ddsnav::sim
