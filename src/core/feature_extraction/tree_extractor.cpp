// ACFR's tree detector (detectTreesI16.m, J. Guivant, ACFR 1999), reimplemented from its
// semantics. Decisions where the wording was ambiguous, settled by the original (details in
// docs/tree_extractor.md):
//  - Every comparison is strict, as in the original: keep r < 75; split on |dr| > 1.5 or
//    gap > 5 deg; clutter if squared distance < 9; neighbours if gap < 1 deg; extent^2 < 1;
//    r_first > 1; first angle > margin and last angle < FOV - margin; |dr| < d / 3.
//  - The clutter rule and the 1-deg rule both look at the original segments (flags are set on all
//    segments first, then the flagged ones are removed), never at already-filtered ones.
//  - The 1-deg rule compares the first range of the later segment with the last range of the
//    earlier one and drops the later one only if it is strictly farther (a tie drops the earlier).
//  - A single-beam segment is a valid candidate (extent 0, d = 0.5 deg * r).
//  - "Middle beam" counts kept beams (beams >= 75 m inside a segment are skipped), and the FOV
//    margin is measured from the first and last beam of the scan.
//  - Ties: many comparisons hit their threshold exactly on this data (a gap of exactly 10 beams
//    = 5 deg, of exactly 2 beams = 1 deg, a jump of exactly 1.50 m). ACFR's result there depends
//    on double rounding (angles (k*pi)/360, ranges cm/100), and the published Victoria Park
//    detections follow that rounding (about 1.4 % of the detections depend on it), so we repeat
//    the same arithmetic in the same order instead of resolving ties "cleanly".
#include "ekf_slam/core/feature_extraction/tree_extractor.h"

#include <cstdio>
#include <ostream>

namespace ekf_slam {
namespace {

struct Segment {
  int first;  // positions in the kept-beam arrays
  int last;
  bool drop;
};

struct Scratch {
  std::vector<int> beam;      // input index of each kept beam
  std::vector<double> range;  // its (rounded) range
  std::vector<double> angle;  // its angle from beam 0
  std::vector<Segment> segments;
};

// Beam angles measured from beam 0, computed the way ACFR's AA = [0:360]*pi/360 is when the
// increment divides pi, so threshold ties round as in the original.
class BeamAngles {
 public:
  explicit BeamAngles(double increment) : step_(std::fabs(increment)) {
    if (step_ > 0.0) {
      const double beams_per_pi = M_PI / step_;
      const double whole = std::round(beams_per_pi);
      if (whole >= 1.0 && std::fabs(beams_per_pi - whole) < 1e-4) {
        divisor_ = whole;
        step_ = M_PI / whole;
      }
    }
  }
  double operator()(int k) const { return divisor_ > 0.0 ? (k * M_PI) / divisor_ : k * step_; }
  double step() const { return step_; }

 private:
  double step_;
  double divisor_ = 0.0;
};

}  // namespace

std::vector<DetectedTree> TreeExtractor::extract(const std::vector<float>& ranges, double angle_min,
                                                 double angle_increment) const {
  std::vector<DetectedTree> trees;
  const int n = static_cast<int>(ranges.size());
  if (n == 0 || !std::isfinite(angle_min) || !std::isfinite(angle_increment)) return trees;

  thread_local Scratch s;
  s.beam.clear();
  s.range.clear();
  s.angle.clear();
  s.segments.clear();

  const BeamAngles angle_of(angle_increment);
  const double res = p_.range_resolution;
  const double per_metre = res > 0.0 ? std::round(1.0 / res) : 0.0;
  // Dividing by a whole count per metre (100) reproduces cm / 100 exactly; r / res * res would not.
  const bool whole_per_metre = res > 0.0 && std::fabs(per_metre * res - 1.0) < 1e-9;

  // 1. Keep beams with a usable return closer than max_range.
  for (int i = 0; i < n; ++i) {
    double r = ranges[i];
    if (!std::isfinite(r)) continue;
    if (whole_per_metre) {
      r = std::nearbyint(r * per_metre) / per_metre;
    } else if (res > 0.0) {
      r = std::nearbyint(r / res) * res;
    }
    if (!(r > 0.0) || !(r < p_.max_range)) continue;
    s.beam.push_back(i);
    s.range.push_back(r);
    s.angle.push_back(angle_of(i));
  }
  const int kept = static_cast<int>(s.beam.size());
  if (kept == 0) return trees;

  // 2. Split into segments at range jumps and angular gaps.
  int start = 0;
  for (int j = 1; j < kept; ++j) {
    if (std::fabs(s.range[j] - s.range[j - 1]) > p_.range_jump ||
        s.angle[j] - s.angle[j - 1] > p_.angle_gap) {
      s.segments.push_back({start, j - 1, false});
      start = j;
    }
  }
  s.segments.push_back({start, kept - 1, false});
  const int count = static_cast<int>(s.segments.size());

  auto x_of = [&](int k) { return s.range[k] * std::cos(s.angle[k]); };
  auto y_of = [&](int k) { return s.range[k] * std::sin(s.angle[k]); };

  // 3. Clutter: a segment ending close to the start of one of the next few hides or is hidden by
  // it; both go.
  const double occlusion2 = p_.occlusion_distance * p_.occlusion_distance;
  for (int a = 0; a < count; ++a) {
    const int end = s.segments[a].last;
    const double xe = x_of(end), ye = y_of(end);
    for (int d = 1; d <= p_.occlusion_lookahead && a + d < count; ++d) {
      const int begin = s.segments[a + d].first;
      const double dx = x_of(begin) - xe, dy = y_of(begin) - ye;
      if (dx * dx + dy * dy < occlusion2) {
        s.segments[a].drop = true;
        s.segments[a + d].drop = true;
      }
    }
  }

  // 4. Neighbours seen almost in the same direction: the one behind is partly hidden; drop it.
  for (int a = 0; a + 1 < count; ++a) {
    const int end = s.segments[a].last, begin = s.segments[a + 1].first;
    if (s.angle[begin] - s.angle[end] < p_.neighbour_angle) {
      s.segments[s.range[begin] > s.range[end] ? a + 1 : a].drop = true;
    }
  }

  // 5. Size, range, field of view and roundness tests on what is left.
  const double extent2 = p_.max_extent * p_.max_extent;
  const double fov = angle_of(n - 1);
  const double direction = angle_increment < 0.0 ? -1.0 : 1.0;
  for (const Segment& seg : s.segments) {
    if (seg.drop) continue;
    const int f = seg.first, l = seg.last;
    const double dx = x_of(f) - x_of(l), dy = y_of(f) - y_of(l);
    if (!(dx * dx + dy * dy < extent2)) continue;
    const double rf = s.range[f], rl = s.range[l], af = s.angle[f], al = s.angle[l];
    if (!(rf > p_.min_range && af > p_.edge_margin && al < fov - p_.edge_margin)) continue;
    // The segment covers one beam width more than its edge-to-edge angle.
    const double diameter = (al + angle_of.step() - af) * (rf + rl) / 2;
    if (!(std::fabs(rf - rl) < diameter / p_.max_range_difference_divisor)) continue;
    // Middle kept beam (mean of the two middle ones for an even count), pushed back to the centre.
    const double middle = (s.range[(f + l) / 2] + s.range[(f + l + 1) / 2]) / 2;
    trees.push_back({middle + diameter / 2, angle_min + direction * ((af + al) * 0.5), diameter,
                     s.beam[f], s.beam[l]});
  }
  return trees;
}

void writeTreesCsvHeader(std::ostream& out) { out << "scan,stamp,range,bearing,diameter\n"; }

void writeTreesCsvRows(std::ostream& out, std::uint32_t scan, double stamp,
                       const std::vector<DetectedTree>& trees) {
  char line[160];
  for (const DetectedTree& t : trees) {
    const int len = std::snprintf(line, sizeof(line), "%u,%.6f,%.6f,%.6f,%.6f\n", scan, stamp,
                                  t.range, t.bearing, t.diameter);
    out.write(line, len);
  }
}

}  // namespace ekf_slam
