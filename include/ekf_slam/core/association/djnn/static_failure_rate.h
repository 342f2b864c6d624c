// DJNN extension "fewer sightings where no mover is seen" (fewer_sightings_without_movers;
// docs/djnn.md): the static test asks for admit_evidence sightings so that it can tell a slow
// mover from a landmark. Where nothing moves, that count only holds landmarks back: at P_D < 1
// the paper's evidence (eq. 9) already reaches admit_evidence in fewer hits, and a camera whose
// passes over a marker give fewer sightings than that never maps it. This part watches the static
// test's own outcomes: a static point fails it by chance in at most 1 - static_probability of its
// tests, so while the failures' share stays below that with 99.9 % confidence there is no mover
// among the features, and admission waits for the paper's evidence alone. The share is looked at
// after every test of a long run, so its level is 0.1 %, not the package's usual 1 %: at 1 %, a
// sensor that sees few features (`arena`: about 60 tests a minute) ruled movers out for minutes
// at a time while its robots seldom failed the test, and let them in (docs/djnn.md).
#pragma once

namespace ekf_slam {

class StaticFailureRate {
 public:
  /// size: the share of a static point's tests that fail by chance (at most); horizon [s]: the
  /// tests of that long ago weigh 1/e (<= 0: all weigh 1).
  void configure(double size, double horizon);
  void reset();
  /// One static test of a feature's sighting at `stamp`, and whether the sighting failed it.
  void tested(bool failed, double stamp);
  /// True once the weighted failures' share is below `size` with 99.9 % confidence (one-sided
  /// Wilson bound): at size 0.1, 87 tests without a failure, more with some.
  bool moversRuledOut() const;
  /// The weighted share and number of tests (for records and tests).
  double share() const { return tests_ > 0.0 ? failures_ / tests_ : 0.0; }
  double tests() const { return tests_; }

 private:
  double size_ = 0.1;
  double horizon_ = 60.0;
  double z_ = 0.0;  ///< the standard normal's 0.999 quantile
  double tests_ = 0.0;
  double failures_ = 0.0;
  double last_stamp_ = 0.0;
  bool started_ = false;
};

}  // namespace ekf_slam
