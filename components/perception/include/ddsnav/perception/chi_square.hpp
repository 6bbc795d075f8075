#pragma once
// Chi-square distribution: the quantile sets the size of the probability-p ellipsoid.

namespace ddsnav::perception {

// Regularized lower incomplete gamma P(a, x) = gamma(a, x) / Gamma(a), a > 0, x >= 0.
// Series expansion below x = a + 1, Lentz continued fraction for Q = 1 - P above.
double regularizedLowerGamma(double a, double x);

// P(X <= x) for X ~ chi-square with `dof` degrees of freedom: P(dof / 2, x / 2).
double chiSquareCdf(double x, int dof);

// x with chiSquareCdf(x, dof) = p, for p in [0, 1) and dof >= 1.
// dof = 2 is closed form, -2 ln(1 - p); otherwise the CDF is inverted numerically
// (bracketing + bisection/Newton to 1e-12 relative). Throws std::invalid_argument outside the domain.
double chiSquareQuantile(double p, int dof);

}  // namespace ddsnav::perception
