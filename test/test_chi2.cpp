// Chi-square CDF and quantiles against published table values.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "ekf_slam/core/common/chi2.h"

namespace ekf_slam {
namespace test_chi2 {

TEST(Chi2, QuantileMatchesTables) {
  // Standard tables (4 decimals).
  EXPECT_NEAR(chi2Quantile(0.95, 1), 3.8415, 1e-4);
  EXPECT_NEAR(chi2Quantile(0.95, 2), 5.9915, 1e-4);
  EXPECT_NEAR(chi2Quantile(0.95, 4), 9.4877, 1e-4);
  EXPECT_NEAR(chi2Quantile(0.95, 20), 31.4104, 1e-4);
  EXPECT_NEAR(chi2Quantile(0.99, 1), 6.6349, 1e-4);
  EXPECT_NEAR(chi2Quantile(0.99, 2), 9.2103, 1e-4);
  EXPECT_NEAR(chi2Quantile(0.05, 2), 0.1026, 1e-4);
  EXPECT_NEAR(chi2Quantile(0.5, 3), 2.3660, 1e-4);
  EXPECT_NEAR(chi2Quantile(0.999, 10), 29.5883, 1e-4);
  EXPECT_NEAR(chi2Quantile(0.95, 100), 124.3421, 1e-4);
  EXPECT_NEAR(chi2Quantile(0.95, 200), 233.9943, 1e-4);
  EXPECT_NEAR(chi2Quantile(0.01, 30), 14.9535, 1e-4);
}

TEST(Chi2, TwoDofClosedForm) {
  // chi2(2) is exponential with mean 2: F(x) = 1 - exp(-x/2), q(p) = -2 ln(1 - p).
  for (double p : {1e-6, 0.01, 0.3, 0.95, 0.9999, 1.0 - 1e-10}) {
    EXPECT_NEAR(chi2Quantile(p, 2), -2.0 * std::log1p(-p), 1e-9 * (1.0 - 2.0 * std::log1p(-p)))
        << p;
  }
  for (double x : {0.01, 1.0, 5.0, 40.0}) {
    EXPECT_NEAR(chi2Cdf(x, 2), 1.0 - std::exp(-0.5 * x), 1e-13) << x;
  }
}

TEST(Chi2, CdfInvertsQuantile) {
  for (int dof : {1, 2, 3, 5, 8, 13, 40, 150}) {
    for (double p : {0.001, 0.05, 0.5, 0.9, 0.95, 0.99, 0.9999}) {
      EXPECT_NEAR(chi2Cdf(chi2Quantile(p, dof), dof), p, 1e-10) << dof << " " << p;
    }
  }
  EXPECT_DOUBLE_EQ(chi2Cdf(0.0, 3), 0.0);
  EXPECT_DOUBLE_EQ(chi2Cdf(-1.0, 3), 0.0);
  EXPECT_NEAR(chi2Cdf(1.0, 1), 0.682689492137, 1e-11);  // P(|N(0,1)| <= 1)
}

TEST(Chi2, TableExtendsLazily) {
  Chi2Table t(0.95, 4);
  EXPECT_DOUBLE_EQ(t.probability(), 0.95);
  EXPECT_NEAR(t(2), 5.9915, 1e-4);
  EXPECT_NEAR(t(4), 9.4877, 1e-4);
  EXPECT_NEAR(t(20), 31.4104, 1e-4);  // past max_dof
  EXPECT_NEAR(t(3), 7.8147, 1e-4);
  EXPECT_THROW(t(0), std::invalid_argument);
  EXPECT_THROW(Chi2Table(1.0, 3), std::invalid_argument);
  EXPECT_THROW(chi2Quantile(0.5, 0), std::invalid_argument);
}

}  // namespace test_chi2
}  // namespace ekf_slam
