#include "transient/reconstruct/polynomial.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <vector>

namespace transient {
namespace {

constexpr double kRootTolerance = 1e-10;  // well separated roots of modulus ~1

// Coefficients (ascending) of lead * prod_l (x - roots[l]).
std::vector<Complex> FromRoots(const std::vector<Complex>& roots, Complex lead) {
  std::vector<Complex> a = {lead};
  for (const Complex& r : roots) {
    std::vector<Complex> next(a.size() + 1, 0.0);
    for (size_t j = 0; j < a.size(); ++j) {
      next[j + 1] += a[j];
      next[j] -= r * a[j];
    }
    a = next;
  }
  return a;
}

TEST(Polynomial, ChosenRootsComeBack) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> radius(0.5, 2.0), angle(0.0, kTwoPi);
  for (int degree = 1; degree <= kMaxPolynomialDegree; degree += 3) {
    std::vector<Complex> roots;
    for (int i = 0; i < degree; ++i) {
      // Spread the angles so the roots stay well separated.
      roots.push_back(std::polar(radius(rng), kTwoPi * i / degree + 0.3 * angle(rng) / degree));
    }
    const auto a = FromRoots(roots, Complex(0.7, -0.2));
    std::vector<Complex> found(a.size() - 1);
    ASSERT_EQ(PolynomialRoots(a, found), degree);
    for (const Complex& r : roots) {
      double best = 1e300;
      for (const Complex& f : found) best = std::min(best, std::abs(f - r));
      EXPECT_LT(best, kRootTolerance * std::pow(10.0, degree / 8)) << "degree " << degree;
    }
  }
}

TEST(Polynomial, NegligibleLeadingCoefficientsLowerTheDegree) {
  const std::vector<Complex> a = {Complex(-2.0), Complex(1.0), Complex(1e-17), Complex(0.0)};
  std::vector<Complex> roots(3);
  ASSERT_EQ(PolynomialRoots(a, roots), 1);
  EXPECT_NEAR(std::abs(roots[0] - Complex(2.0)), 0.0, 1e-15);
}

TEST(Polynomial, ConstantPolynomialHasNoRoots) {
  const std::vector<Complex> a = {Complex(3.0), Complex(0.0)};
  std::vector<Complex> roots(1);
  EXPECT_EQ(PolynomialRoots(a, roots), 0);
}

TEST(Polynomial, HornerEvaluation) {
  const std::vector<Complex> a = {1.0, 2.0, 3.0};  // 1 + 2x + 3x^2
  EXPECT_EQ(EvaluatePolynomial(a, Complex(2.0)), Complex(17.0));
}

}  // namespace
}  // namespace transient
