#include "ddsnav/perception/chi_square.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

namespace ddsnav::perception {

double regularizedLowerGamma(double a, double x) {
  if (!(a > 0.0) || !(x >= 0.0)) throw std::invalid_argument("regularizedLowerGamma: need a > 0 and x >= 0");
  if (x == 0.0) return 0.0;
  if (std::isinf(x)) return 1.0;
  const double log_prefix = a * std::log(x) - x - std::lgamma(a);  // ln(x^a e^-x / Gamma(a))
  if (x < a + 1.0) {
    // P = x^a e^-x / Gamma(a+1) * sum_n x^n / ((a+1)...(a+n))
    double term = 1.0 / a, sum = term;
    for (int n = 1; n < 1000; ++n) {
      term *= x / (a + n);
      sum += term;
      if (std::abs(term) < std::abs(sum) * 1e-16) break;
    }
    return std::exp(log_prefix) * sum;
  }
  // Q = x^a e^-x / Gamma(a) * 1 / (x + 1 - a - 1(1-a)/(x + 3 - a - 2(2-a)/(x + 5 - a - ...)))
  // evaluated with the modified Lentz algorithm.
  constexpr double tiny = 1e-300;
  double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
  for (int i = 1; i < 1000; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1.0) < 1e-16) break;
  }
  return 1.0 - std::exp(log_prefix) * h;
}

double chiSquareCdf(double x, int dof) {
  if (dof < 1) throw std::invalid_argument("chiSquareCdf: dof must be >= 1");
  if (x <= 0.0) return 0.0;
  return regularizedLowerGamma(0.5 * dof, 0.5 * x);
}

static double invertCdf(double p, int dof);

double chiSquareQuantile(double p, int dof) {
  if (dof < 1) throw std::invalid_argument("chiSquareQuantile: dof must be >= 1, got " + std::to_string(dof));
  if (!(p >= 0.0 && p < 1.0))
    throw std::invalid_argument("chiSquareQuantile: p must be in [0, 1), got " + std::to_string(p));
  if (p == 0.0) return 0.0;
  if (dof == 2) return -2.0 * std::log1p(-p);

  // Callers ask for the same (p, dof) once per obstacle: remember the last answers.
  struct Cached {
    double p;
    int dof;
    double x;
  };
  thread_local Cached cache[4] = {{-1, 0, 0}, {-1, 0, 0}, {-1, 0, 0}, {-1, 0, 0}};
  thread_local int next_slot = 0;
  for (const auto& c : cache)
    if (c.p == p && c.dof == dof) return c.x;
  const double x = invertCdf(p, dof);
  cache[next_slot] = {p, dof, x};
  next_slot = (next_slot + 1) % 4;
  return x;
}

// Numerical inverse of the CDF for p in (0, 1).
static double invertCdf(double p, int dof) {
  // Bracket: the CDF is increasing; grow the upper end until it passes p.
  double lo = 0.0, hi = std::max(1.0, static_cast<double>(dof));
  while (chiSquareCdf(hi, dof) < p) {
    lo = hi;
    hi *= 2.0;
    if (hi > 1e8) return std::numeric_limits<double>::infinity();
  }
  // Newton steps inside the bracket, falling back to bisection when a step leaves it.
  const double k = 0.5 * dof;
  double x = 0.5 * (lo + hi);
  for (int i = 0; i < 200; ++i) {
    const double f = chiSquareCdf(x, dof) - p;
    if (f > 0.0) hi = x; else lo = x;
    // density of chi-square: x^(k-1) e^(-x/2) / (2^k Gamma(k))
    const double log_pdf = (k - 1.0) * std::log(x) - 0.5 * x - k * std::log(2.0) - std::lgamma(k);
    double next = x - f / std::exp(log_pdf);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (std::abs(next - x) <= 1e-12 * x) return next;
    x = next;
  }
  return x;
}

}  // namespace ddsnav::perception
