#include "ddsnav/perception/chi_square.hpp"

#include <gtest/gtest.h>

#include <cmath>

namespace ddsnav::perception {
namespace {

TEST(ChiSquare, QuantilesMatchTables) {
  EXPECT_NEAR(chiSquareQuantile(0.99, 3), 11.344867, 1e-5);
  EXPECT_NEAR(chiSquareQuantile(0.95, 3), 7.814728, 1e-5);
  EXPECT_NEAR(chiSquareQuantile(0.50, 3), 2.365974, 1e-5);
  EXPECT_NEAR(chiSquareQuantile(0.99, 2), 9.210340, 1e-5);
  EXPECT_NEAR(chiSquareQuantile(0.95, 1), 3.841459, 1e-5);
  EXPECT_NEAR(chiSquareQuantile(0.50, 1), 0.454936, 1e-5);
  EXPECT_NEAR(chiSquareQuantile(0.90, 5), 9.236357, 1e-5);
  EXPECT_NEAR(chiSquareQuantile(0.999, 3), 16.266236, 1e-4);
  EXPECT_EQ(chiSquareQuantile(0.0, 3), 0.0);
}

TEST(ChiSquare, CdfHasClosedFormsForSmallDof) {
  for (double x : {0.1, 1.0, 4.0, 11.0, 30.0}) {
    EXPECT_NEAR(chiSquareCdf(x, 2), 1.0 - std::exp(-x / 2), 1e-13);
    EXPECT_NEAR(chiSquareCdf(x, 1), std::erf(std::sqrt(x / 2)), 1e-13);
    // dof 3: erf(sqrt(x/2)) - sqrt(2x/pi) exp(-x/2)
    EXPECT_NEAR(chiSquareCdf(x, 3), std::erf(std::sqrt(x / 2)) - std::sqrt(2 * x / M_PI) * std::exp(-x / 2), 1e-13);
  }
}

TEST(ChiSquare, QuantileInvertsCdf) {
  for (int dof : {1, 2, 3, 4, 7}) {
    for (double p : {0.01, 0.3, 0.9, 0.99, 0.9999}) EXPECT_NEAR(chiSquareCdf(chiSquareQuantile(p, dof), dof), p, 1e-10);
  }
}

TEST(ChiSquare, RejectsOutOfDomain) {
  EXPECT_THROW(chiSquareQuantile(1.0, 3), std::invalid_argument);
  EXPECT_THROW(chiSquareQuantile(-0.1, 3), std::invalid_argument);
  EXPECT_THROW(chiSquareQuantile(std::nan(""), 3), std::invalid_argument);
  EXPECT_THROW(chiSquareQuantile(0.5, 0), std::invalid_argument);
}

}  // namespace
}  // namespace ddsnav::perception
