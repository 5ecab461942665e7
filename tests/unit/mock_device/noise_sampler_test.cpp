// The sensor's noise samplers against the laws they sample: the Poisson law's mean,
// variance and probabilities over means from 0.05 to 1e5 electrons (both algorithms and
// the switch between them), the standard normal's moments, bins and tails, and the
// independence of neighbouring counters. The truths are written out here from the laws'
// formulas (std::lgamma, std::erfc), not from the samplers.
#include "mock_device/render/noise_sampler.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <vector>

namespace camlab::mock::noise {
namespace {

constexpr uint64_t kKey = 0x5EED5EED1234ull;

// The chi-square statistic's critical value at p = 1e-6 for `dof` degrees of freedom
// (Wilson-Hilferty: chi2/dof is nearly normal after a cube root; z = 4.75 for 1e-6).
double chi_square_critical(int dof) {
  const double z = 4.75, c = 2.0 / (9.0 * dof);
  return dof * std::pow(1 - c + z * std::sqrt(c), 3);
}

// The Poisson probability of k from the law itself: exp(k log m - m - log k!).
double poisson_pmf(int64_t k, double mean) {
  return std::exp(static_cast<double>(k) * std::log(mean) - mean -
                  std::lgamma(static_cast<double>(k) + 1));
}

struct Moments {
  double mean = 0, variance = 0;
};

Moments moments(const std::vector<double>& x) {
  double sum = 0;
  for (double v : x) sum += v;
  Moments m;
  m.mean = sum / static_cast<double>(x.size());
  double ss = 0;
  for (double v : x) ss += (v - m.mean) * (v - m.mean);
  m.variance = ss / static_cast<double>(x.size() - 1);
  return m;
}

class PoissonMoments : public ::testing::TestWithParam<double> {};
class PoissonCounts : public ::testing::TestWithParam<double> {};

TEST_P(PoissonMoments, MeanAndVarianceAreTheMean) {
  const double mean = GetParam();
  constexpr int kDraws = 400000;
  std::vector<double> x(kDraws);
  for (int i = 0; i < kDraws; ++i) x[i] = static_cast<double>(poisson(mean, kKey, i));
  const Moments m = moments(x);
  // Five standard errors: the sample mean's is sqrt(m / n), the sample variance's
  // sqrt((m + 2 m^2) / n) for the Poisson law (its fourth central moment is m + 3 m^2).
  EXPECT_NEAR(m.mean, mean, 5 * std::sqrt(mean / kDraws)) << "mean " << mean;
  EXPECT_NEAR(m.variance, mean, 5 * std::sqrt((mean + 2 * mean * mean) / kDraws))
      << "mean " << mean;
}

TEST_P(PoissonCounts, CountsFollowTheProbabilitiesOfTheLaw) {
  const double mean = GetParam();
  constexpr int kDraws = 400000;
  std::map<int64_t, int> counts;
  for (int i = 0; i < kDraws; ++i) ++counts[poisson(mean, kKey ^ 0xABCDEF, i)];
  // Bins of k with an expected count of 20 or more each; the two tails pooled.
  const int64_t mode = static_cast<int64_t>(mean);
  int64_t lo = mode, hi = mode;
  while (lo > 0 && kDraws * poisson_pmf(lo - 1, mean) >= 20) --lo;
  while (kDraws * poisson_pmf(hi + 1, mean) >= 20) ++hi;
  double p_inside = 0, chi2 = 0;
  int observed_inside = 0;
  for (int64_t k = lo; k <= hi; ++k) {
    const double expected = kDraws * poisson_pmf(k, mean);
    const int observed = counts.count(k) ? counts[k] : 0;
    chi2 += (observed - expected) * (observed - expected) / expected;
    p_inside += poisson_pmf(k, mean);
    observed_inside += observed;
  }
  const double expected_outside = kDraws * (1 - p_inside);
  const double observed_outside = kDraws - observed_inside;
  int dof = static_cast<int>(hi - lo);
  if (expected_outside >= 5) {
    chi2 += (observed_outside - expected_outside) * (observed_outside - expected_outside) /
            expected_outside;
    ++dof;
  }
  ASSERT_GE(dof, 1);
  EXPECT_LT(chi2, chi_square_critical(dof))
      << "mean " << mean << ": k in [" << lo << ", " << hi << "], " << dof << " dof";
}

// Below 1 e-, both sides of the switch from inversion to PTRS (10), and up to bright
// pixels of large wells; the probabilities bin by bin up to 1000 e-, where the law is
// already nearly Gaussian and the moments say the rest.
INSTANTIATE_TEST_SUITE_P(Means, PoissonMoments,
                         ::testing::Values(0.05, 0.4, 0.97, 2.5, 6.0, 9.99, 10.0, 10.5, 17.3, 42.0,
                                           137.0, 1000.0, 4321.0, 1e5));
INSTANTIATE_TEST_SUITE_P(Means, PoissonCounts,
                         ::testing::Values(0.05, 0.4, 0.97, 2.5, 6.0, 9.99, 10.0, 10.5, 17.3, 42.0,
                                           137.0, 1000.0));

TEST(PoissonSampler, NoMeanGivesNoElectrons) {
  EXPECT_EQ(poisson(0.0, kKey, 1), 0);
  EXPECT_EQ(poisson(-3.0, kKey, 1), 0);
  EXPECT_EQ(poisson(std::nan(""), kKey, 1), 0);
}

TEST(PoissonSampler, ADrawIsAFunctionOfKeyAndIndexOnly) {
  // The same draw whatever was drawn before it or in which order (threads split a frame
  // into any rows).
  std::vector<int64_t> forward, backward(1000);
  for (int i = 0; i < 1000; ++i) forward.push_back(poisson(500.0, kKey, i));
  for (int i = 999; i >= 0; --i) backward[i] = poisson(500.0, kKey, i);
  EXPECT_EQ(forward, backward);
  int differ = 0;
  for (int i = 0; i < 1000; ++i) differ += poisson(500.0, kKey + 1, i) != forward[i];
  EXPECT_GT(differ, 900) << "another key (frame) is another draw";
}

TEST(NormalSampler, MomentsAreThoseOfTheStandardNormal) {
  constexpr int kDraws = 1000000;
  std::vector<double> x(kDraws);
  for (int i = 0; i < kDraws; ++i) x[i] = standard_normal(kKey, i);
  const Moments m = moments(x);
  double m3 = 0, m4 = 0;
  for (double v : x) {
    m3 += v * v * v;
    m4 += v * v * v * v;
  }
  m3 /= kDraws;
  m4 /= kDraws;
  // Standard errors: 1/sqrt(n), sqrt(2/n), sqrt(15/n) and sqrt(96/n).
  EXPECT_NEAR(m.mean, 0.0, 5 / std::sqrt(kDraws));
  EXPECT_NEAR(m.variance, 1.0, 5 * std::sqrt(2.0 / kDraws));
  EXPECT_NEAR(m3, 0.0, 5 * std::sqrt(15.0 / kDraws));
  EXPECT_NEAR(m4, 3.0, 5 * std::sqrt(96.0 / kDraws));
}

TEST(NormalSampler, BinsAndTailsFollowTheNormalLaw) {
  constexpr int kDraws = 2000000;
  // 64 bins of 0.125 from -4 to 4, and the two tails beyond: the probabilities from
  // erfc, so the layers and their wedges are all checked.
  constexpr int kBins = 64;
  std::vector<int> counts(kBins + 2, 0);
  for (int i = 0; i < kDraws; ++i) {
    const double z = standard_normal(kKey ^ 0x77, i);
    const int bin = z < -4   ? 0
                    : z >= 4 ? kBins + 1
                             : std::min(kBins, 1 + static_cast<int>((z + 4) / 0.125));
    ++counts[bin];
  }
  auto cdf = [](double z) { return 0.5 * std::erfc(-z / std::sqrt(2.0)); };
  double chi2 = 0;
  for (int b = 0; b < kBins + 2; ++b) {
    const double lo = b == 0 ? -INFINITY : -4 + (b - 1) * 0.125;
    const double hi = b == kBins + 1 ? INFINITY : -4 + b * 0.125;
    const double expected =
        kDraws * ((std::isinf(hi) ? 1.0 : cdf(hi)) - (std::isinf(lo) ? 0.0 : cdf(lo)));
    chi2 += (counts[b] - expected) * (counts[b] - expected) / expected;
  }
  EXPECT_LT(chi2, chi_square_critical(kBins + 1));
}

TEST(NormalSampler, TheTailBeyondTheBaseLayerFollowsTheLaw) {
  // Draws beyond the base layer (|z| > 3.44) come from a sampler of their own: count them
  // past 3.7, 4 and 4.5 in enough draws to see a tail 20% too heavy.
  constexpr int kDraws = 8000000;
  int beyond[3] = {0, 0, 0};
  constexpr double kEdges[3] = {3.7, 4.0, 4.5};
  for (int i = 0; i < kDraws; ++i) {
    const double z = std::fabs(standard_normal(kKey ^ 0x99, i));
    for (int e = 0; e < 3; ++e) beyond[e] += z > kEdges[e];
  }
  for (int e = 0; e < 3; ++e) {
    const double expected = kDraws * std::erfc(kEdges[e] / std::sqrt(2.0));
    EXPECT_NEAR(beyond[e], expected, 5 * std::sqrt(expected)) << "|z| > " << kEdges[e];
  }
}

TEST(NormalSampler, NeighbouringCountersAndKeysAreUncorrelated) {
  // Pixels next to each other use neighbouring indices; frames use neighbouring keys.
  constexpr int kDraws = 500000;
  double along = 0, across = 0;
  for (int i = 0; i < kDraws; ++i) {
    const double z = standard_normal(kKey, i);
    along += z * standard_normal(kKey, i + 1);
    across += z * standard_normal(kKey + 1, i);
  }
  EXPECT_NEAR(along / kDraws, 0.0, 5 / std::sqrt(kDraws));
  EXPECT_NEAR(across / kDraws, 0.0, 5 / std::sqrt(kDraws));
}

TEST(LogFactorial, MatchesLogGammaOnBothSidesOfTheTable) {
  for (int64_t k : {0, 1, 2, 10, 63, 64, 65, 100, 1000, 16383, 16384, 16385, 123456}) {
    const double truth = std::lgamma(static_cast<double>(k) + 1);
    EXPECT_NEAR(log_factorial(k), truth, 1e-13 * std::max(1.0, truth)) << k;
  }
}

// The row samplers are the scalar ones reorganised for speed: the same deviate for every
// mean and index, to the bit, including the draws their fast pass hands back (PTRS's
// exact test and its fallback, the ziggurat's wedges and tail) and means outside PTRS's
// range (0, negative, NaN, inversion, the switch at 10).
TEST(RowSamplers, PoissonRowDrawsWhatTheLawDraws) {
  std::vector<double> means = {0,       -3,   std::nan(""), 0.05, 0.5,  3,     9.999999, 10,
                               10.0001, 37.5, 999.9,        1000, 6000, 12000, 1e5,      1e7};
  // A falloff-like ramp (every pixel its own mean) across both algorithms.
  for (int i = 0; i < 20000; ++i) means.push_back(15.0 * i * i / 20000.0 + 0.37 * i);
  std::vector<int64_t> row(means.size());
  std::vector<uint8_t> scratch;
  for (uint64_t first : {0ull, 12345ull, 0xFFFFFFFFull}) {
    poisson_row(means.data(), row.data(), static_cast<int>(means.size()), kKey, first, scratch);
    int64_t mismatches = 0;
    for (size_t i = 0; i < means.size(); ++i)
      if (row[i] != poisson(means[i], kKey, first + i)) ++mismatches;
    EXPECT_EQ(mismatches, 0) << "first index " << first;
  }
  // The fast pass accepted some and handed some back: both branches ran.
  size_t handed_back = 0;
  for (uint8_t flag : scratch) handed_back += flag;
  EXPECT_GT(handed_back, means.size() / 20);
  EXPECT_LT(handed_back, means.size() / 2);
}

TEST(RowSamplers, NormalRowDrawsWhatTheScalarSamplerDraws) {
  constexpr int kCount = 200000;  // about 2000 wedge or tail draws handed back
  std::vector<double> row(kCount);
  std::vector<uint8_t> scratch;
  standard_normal_row(row.data(), kCount, kKey, 777, scratch);
  int64_t mismatches = 0, handed_back = 0;
  for (int i = 0; i < kCount; ++i) {
    if (row[static_cast<size_t>(i)] != standard_normal(kKey, 777 + static_cast<uint64_t>(i)))
      ++mismatches;
    handed_back += scratch[static_cast<size_t>(i)];
  }
  EXPECT_EQ(mismatches, 0);
  EXPECT_GT(handed_back, kCount / 500);
}

}  // namespace
}  // namespace camlab::mock::noise
