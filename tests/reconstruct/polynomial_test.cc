#include "transient/reconstruct/polynomial.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
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

// The largest distance from a root in `expected` to the nearest of `found`.
double WorstRootDistance(const std::vector<Complex>& expected, const std::vector<Complex>& found) {
  double worst = 0.0;
  for (const Complex& r : expected) {
    double best = 1e300;
    for (const Complex& f : found) best = std::min(best, std::abs(f - r));
    worst = std::max(worst, best);
  }
  return worst;
}

TEST(Polynomial, AberthFindsTheCompanionMatrixsRoots) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> radius(0.5, 2.0), angle(0.0, kTwoPi), part(-1.0, 1.0);
  int declined = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const int degree = 2 + trial % (kMaxPolynomialDegree - 1);
    std::vector<Complex> a;
    if (trial % 2 == 0) {  // chosen roots, well separated
      std::vector<Complex> roots;
      for (int i = 0; i < degree; ++i) {
        roots.push_back(std::polar(radius(rng), kTwoPi * i / degree + 0.3 * angle(rng) / degree));
      }
      a = FromRoots(roots, Complex(part(rng), part(rng)));
    } else {  // random coefficients
      for (int j = 0; j <= degree; ++j) a.emplace_back(part(rng), part(rng));
    }
    std::vector<Complex> aberth(degree), companion(degree);
    if (!AberthRoots(a, aberth)) {
      ++declined;
      continue;
    }
    ASSERT_EQ(PolynomialRoots(a, companion), degree);
    double scale = 0.0;
    for (const Complex& r : companion) scale = std::max(scale, std::abs(r));
    EXPECT_LT(WorstRootDistance(companion, aberth), 1e-9 * scale) << "trial " << trial;
  }
  EXPECT_LE(declined, 4) << "of 400 polynomials";
  RecordProperty("declined", declined);
}

TEST(Polynomial, AberthDeclinesARootAtZeroAndValuesNotFinite) {
  std::vector<Complex> roots(3);
  // x (x - 1)(x + 2): the geometric mean modulus of the roots is 0.
  EXPECT_FALSE(AberthRoots(FromRoots({0.0, 1.0, -2.0}, 1.0), roots));
  auto with_nan = FromRoots({1.0, 2.0, -2.0}, 1.0);
  with_nan[1] = Complex(std::nan(""), 0.0);
  EXPECT_FALSE(AberthRoots(with_nan, roots));
  auto with_infinity = FromRoots({1.0, 2.0, -2.0}, 1.0);
  with_infinity[2] = Complex(0.0, INFINITY);
  EXPECT_FALSE(AberthRoots(with_infinity, roots));
  // PolynomialRoots then takes the companion matrix's eigenvalues: the same roots as without.
  const auto zero_root = FromRoots({0.0, 1.0, -2.0}, 1.0);
  std::vector<Complex> companion(3);
  ASSERT_EQ(PolynomialRoots(zero_root, roots, RootMethod::kAberth), 3);
  ASSERT_EQ(PolynomialRoots(zero_root, companion), 3);
  EXPECT_EQ(roots, companion);
}

TEST(Polynomial, AberthFindsADoubleRootAsWellAsTheCompanionMatrix) {
  // (x - 1)^2 (x + 2): a double root is found to ~sqrt(eps) by either method.
  const auto a = FromRoots({1.0, 1.0, -2.0}, 1.0);
  std::vector<Complex> aberth(3), companion(3);
  ASSERT_TRUE(AberthRoots(a, aberth));
  ASSERT_EQ(PolynomialRoots(a, companion), 3);
  EXPECT_LT(WorstRootDistance({1.0, 1.0, -2.0}, aberth), 1e-7);
  EXPECT_LT(WorstRootDistance({1.0, 1.0, -2.0}, companion), 1e-7);
  EXPECT_LT(WorstRootDistance(aberth, {1.0, -2.0}), 1e-7);  // no third root elsewhere
}

TEST(Polynomial, NegligibleLeadingCoefficientsLowerTheDegree) {
  const std::vector<Complex> a = {Complex(-2.0), Complex(1.0), Complex(1e-17), Complex(0.0)};
  std::vector<Complex> roots(3);
  ASSERT_EQ(PolynomialRoots(a, roots), 1);
  EXPECT_NEAR(std::abs(roots[0] - Complex(2.0)), 0.0, 1e-15);
  // By Aberth's iteration too: (x - 2)(x + 3) with a negligible cubic term.
  const std::vector<Complex> b = {Complex(-6.0), Complex(1.0), Complex(1.0), Complex(1e-16)};
  ASSERT_EQ(PolynomialRoots(b, roots, RootMethod::kAberth), 2);
  EXPECT_LT(WorstRootDistance({2.0, -3.0}, {roots[0], roots[1]}), 1e-14);
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
