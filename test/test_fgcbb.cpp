// FGCBB and GCBB on crafted maps: found with the right pose and pairings on an irregular map,
// never a confident wrong pose (regular grid, point-symmetric map, robot outside the map, a
// wrong prior), clear answers for bad input (empty map, < 3 observations, NaN descriptors).
#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <set>
#include <string>

#include "ekf_slam/core/relocalisation/fgcbb.h"
#include "ekf_slam/core/relocalisation/gcbb.h"
#include "relocalisation_fixtures.h"

namespace ekf_slam {
namespace test_fgcbb {

using reloc_test::World;

MapParameterSource params(const std::string& name, const std::string& value) {
  MapParameterSource p;
  p.set(name, value);
  return p;
}

// The scans below see 15 m around the sensor: two trees seen together are up to 30 m apart, so
// C_ij takes R = 30 (with the paper's R = 16 the sparse forests here leave groups too few pairs).
std::unique_ptr<GeometricConstraintBB> make(const std::string& name) {
  std::unique_ptr<GeometricConstraintBB> r;
  if (name == "GCBB") {
    r = std::make_unique<GCBB>();
  } else {
    r = std::make_unique<FGCBB>();
  }
  r->configure(params("sensor_range", "30"));
  return r;
}

class Relocalisers : public testing::TestWithParam<std::string> {};

// The right answer: found, within 0.5 m and 2 deg, and every pairing the truth's.
void expectCorrect(const RelocalisationResult& r, const Eigen::Vector3d& truth,
                   const std::vector<LandmarkId>& ids, int min_pairings) {
  ASSERT_EQ(r.status, RelocalisationStatus::kFound) << r.reason;
  EXPECT_LT(reloc_test::positionError(r.pose, truth), 0.5);
  EXPECT_LT(reloc_test::headingError(r.pose, truth), deg2rad(2.0));
  ASSERT_EQ(r.landmark.size(), ids.size());
  int paired = 0;
  for (std::size_t i = 0; i < ids.size(); ++i) {
    if (r.landmark[i] == kNoLandmark) continue;
    ++paired;
    EXPECT_EQ(r.landmark[i], ids[i]) << "observation " << i;
  }
  EXPECT_EQ(paired, r.hypothesis_size);
  EXPECT_GE(paired, min_pairings);
  EXPECT_GT(r.nodes, 0u);
  EXPECT_TRUE(std::isfinite(r.joint_mahalanobis));
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(r.covariance);
  EXPECT_GT(es.eigenvalues().minCoeff(), 0.0);
}

// Never a confident wrong pose.
void expectNotWrong(const RelocalisationResult& r, const Eigen::Vector3d& truth) {
  if (r.status != RelocalisationStatus::kFound) return;
  EXPECT_LT(reloc_test::positionError(r.pose, truth), 1.0) << "confident wrong pose";
  EXPECT_LT(reloc_test::headingError(r.pose, truth), deg2rad(5.0)) << "confident wrong pose";
}

TEST_P(Relocalisers, FindsThePoseInAnIrregularMapWithoutPrior) {
  const World w = reloc_test::randomMap(200, 120.0, 3.0, 11);
  auto reloc = make(GetParam());
  reloc->setMap(w.map);
  int found = 0;
  for (int k = 0; k < 10; ++k) {
    const Eigen::Vector3d truth(30.0 + 6.0 * k, 25.0 + 7.0 * k, -3.0 + 0.6 * k);
    std::vector<LandmarkId> ids;
    const auto obs = w.observe(truth, 15.0, &ids, true, 100 + k);
    if (obs.size() < 6) continue;
    SCOPED_TRACE("pose " + std::to_string(k) + ", " + std::to_string(obs.size()) + " obs");
    expectCorrect(reloc->relocalise(obs, w.sensor_offset, nullptr), truth, ids, 5);
    ++found;
  }
  EXPECT_GE(found, 6);
}

TEST_P(Relocalisers, ClutterObservationsStayUnpaired) {
  const World w = reloc_test::randomMap(200, 120.0, 3.0, 12);
  auto reloc = make(GetParam());
  reloc->setMap(w.map);
  const Eigen::Vector3d truth(60, 60, 0.7);
  std::vector<LandmarkId> ids;
  auto obs = w.observe(truth, 15.0, &ids);
  ASSERT_GE(obs.size(), 6u);
  for (const double b : {-2.0, 0.3, 2.5}) {  // three returns from no landmark
    Observation o = obs[0];
    o.z = Eigen::Vector2d(7.3 + b, b);
    obs.push_back(o);
    ids.push_back(kNoLandmark);
  }
  const auto r = reloc->relocalise(obs, w.sensor_offset, nullptr);
  expectCorrect(r, truth, ids, 5);
}

TEST_P(Relocalisers, UsesThePriorToGateCandidates) {
  const World w = reloc_test::randomMap(200, 120.0, 3.0, 13);
  auto reloc = make(GetParam());
  reloc->setMap(w.map);
  const Eigen::Vector3d truth(50, 70, -1.2);
  std::vector<LandmarkId> ids;
  const auto obs = w.observe(truth, 15.0, &ids);
  ASSERT_GE(obs.size(), 5u);
  PosePrior good;
  good.mean = truth + Eigen::Vector3d(1.0, -1.0, 0.05);
  good.covariance = Eigen::Vector3d(4.0, 4.0, 0.04).asDiagonal();
  const auto with_prior = reloc->relocalise(obs, w.sensor_offset, &good);
  expectCorrect(with_prior, truth, ids, 5);
  const auto global = reloc->relocalise(obs, w.sensor_offset, nullptr);
  EXPECT_LT(with_prior.nodes, global.nodes);  // the prior prunes the search
  // A confident prior 30 m off: no landmark passes its gate, so nothing is found.
  PosePrior wrong = good;
  wrong.mean = truth + Eigen::Vector3d(30.0, 0.0, 0.0);
  wrong.covariance = Eigen::Vector3d(1.0, 1.0, 0.01).asDiagonal();
  const auto r = reloc->relocalise(obs, w.sensor_offset, &wrong);
  EXPECT_NE(r.status, RelocalisationStatus::kFound);
  PosePrior nan = good;
  nan.mean.x() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(reloc->relocalise(obs, w.sensor_offset, &nan).status, RelocalisationStatus::kNotFound);
}

TEST_P(Relocalisers, RegularGridIsAmbiguous) {
  const World w = reloc_test::gridMap(12, 12, 5.0);
  auto reloc = make(GetParam());
  reloc->configure(params("sensor_range", "12"));  // as far as the scan sees
  reloc->setMap(w.map);
  const Eigen::Vector3d truth(27.0, 26.0, 0.3);  // in the middle: every shift fits as well
  std::vector<LandmarkId> ids;
  const auto obs = w.observe(truth, 12.0, &ids);
  ASSERT_GE(obs.size(), 6u);
  const auto r = reloc->relocalise(obs, w.sensor_offset, nullptr);
  EXPECT_EQ(r.status, RelocalisationStatus::kAmbiguous) << r.reason;
  EXPECT_FALSE(r.reason.empty());
  // With a prior tight enough to pick one cell, it is found.
  PosePrior prior;
  prior.mean = truth + Eigen::Vector3d(0.5, -0.5, 0.02);
  prior.covariance = Eigen::Vector3d(0.5, 0.5, 0.005).asDiagonal();
  expectCorrect(reloc->relocalise(obs, w.sensor_offset, &prior), truth, ids, 5);
}

TEST_P(Relocalisers, PointSymmetricMapIsAmbiguous) {
  // Each landmark has its twin at (100, 100) - p: a pose and its 180-degree turn about the
  // centre see exactly the same scan.
  const World half = reloc_test::randomMap(150, 100.0, 3.0, 14);
  World w;
  for (const MapLandmark& l : half.map) {
    if (l.position.x() + l.position.y() > 100.0) continue;
    w.add(l.position.x(), l.position.y());
    w.add(100.0 - l.position.x(), 100.0 - l.position.y());
  }
  auto reloc = make(GetParam());
  reloc->setMap(w.map);
  for (const Eigen::Vector3d& truth :
       {Eigen::Vector3d(40, 45, 0.4), Eigen::Vector3d(50, 50, 2.0)}) {
    std::vector<LandmarkId> ids;
    const auto obs = w.observe(truth, 15.0, &ids);
    if (obs.size() < 5) continue;
    const auto r = reloc->relocalise(obs, w.sensor_offset, nullptr);
    EXPECT_EQ(r.status, RelocalisationStatus::kAmbiguous) << r.reason;
  }
}

TEST_P(Relocalisers, MirrorSymmetricMapIsNotFooledByTheReflection) {
  // Mirror image about x = 50: pairwise distances cannot tell the two halves apart, but the
  // reflection is no rigid motion, so the joint test rejects the mirrored pairing.
  const World half = reloc_test::randomMap(150, 100.0, 3.0, 15);
  World w;
  for (const MapLandmark& l : half.map) {
    if (l.position.x() >= 50.0) continue;
    w.add(l.position.x(), l.position.y());
    w.add(100.0 - l.position.x(), l.position.y());
  }
  auto reloc = make(GetParam());
  reloc->setMap(w.map);
  int found = 0;
  for (int k = 0; k < 8; ++k) {
    // Poses on both sides and on the axis, some facing along it.
    const Eigen::Vector3d truth(30.0 + 6.0 * k, 25.0 + 7.0 * k, k % 2 ? M_PI / 2 : 0.8 * k);
    std::vector<LandmarkId> ids;
    const auto obs = w.observe(truth, 15.0, &ids);
    if (obs.size() < 6) continue;
    const auto r = reloc->relocalise(obs, w.sensor_offset, nullptr);
    expectNotWrong(r, truth);
    found += r.status == RelocalisationStatus::kFound;
  }
  EXPECT_GE(found, 4);
}

TEST_P(Relocalisers, OutsideTheMapNothingIsFound) {
  // The scan comes from another forest: nothing in the map explains it.
  const World map = reloc_test::randomMap(200, 120.0, 3.0, 16);
  const World elsewhere = reloc_test::randomMap(200, 120.0, 3.0, 17);
  auto reloc = make(GetParam());
  reloc->setMap(map.map);
  for (int k = 0; k < 8; ++k) {
    const Eigen::Vector3d pose(30.0 + 8.0 * k, 40.0 + 5.0 * k, 0.8 * k);
    const auto obs = elsewhere.observe(pose, 15.0, nullptr, true, k);
    const auto r = reloc->relocalise(obs, map.sensor_offset, nullptr);
    EXPECT_NE(r.status, RelocalisationStatus::kFound)
        << "pose " << k << ": " << r.hypothesis_size << " of " << obs.size()
        << " observations paired, D^2 " << r.joint_mahalanobis << ", " << r.nodes << " nodes";
  }
}

TEST_P(Relocalisers, EmptyMapAndTooFewObservationsAreNotFound) {
  auto reloc = make(GetParam());
  const World w = reloc_test::randomMap(200, 120.0, 3.0, 18);
  const Eigen::Vector3d truth(60, 60, 0.0);
  std::vector<LandmarkId> ids;
  const auto obs = w.observe(truth, 15.0, &ids);
  ASSERT_GE(obs.size(), 5u);
  // No map yet, then an empty one.
  auto r = reloc->relocalise(obs, w.sensor_offset, nullptr);
  EXPECT_EQ(r.status, RelocalisationStatus::kNotFound);
  EXPECT_NE(r.reason.find("landmarks"), std::string::npos) << r.reason;
  reloc->setMap({});
  EXPECT_EQ(reloc->relocalise(obs, w.sensor_offset, nullptr).status,
            RelocalisationStatus::kNotFound);
  reloc->setMap(w.map);
  const std::vector<Observation> two(obs.begin(), obs.begin() + 2);
  r = reloc->relocalise(two, w.sensor_offset, nullptr);
  EXPECT_EQ(r.status, RelocalisationStatus::kNotFound);
  EXPECT_NE(r.reason.find("observations"), std::string::npos) << r.reason;
  EXPECT_EQ(r.landmark.size(), 2u);
  r = reloc->relocalise({}, w.sensor_offset, nullptr);
  EXPECT_EQ(r.status, RelocalisationStatus::kNotFound);
  EXPECT_TRUE(r.landmark.empty());
}

TEST_P(Relocalisers, NaNDescriptorsAreSkippedAndGoodOnesPrune) {
  World w = reloc_test::randomMap(200, 120.0, 3.0, 19);
  auto reloc = make(GetParam());
  const Eigen::Vector3d truth(55, 45, 1.0);
  std::vector<LandmarkId> ids;
  // NaN everywhere (the default): found all the same.
  reloc->setMap(w.map);
  auto obs = w.observe(truth, 15.0, &ids);
  const auto without = reloc->relocalise(obs, w.sensor_offset, nullptr);
  expectCorrect(without, truth, ids, 5);
  // Trunk diameters on every landmark (some observations without one): found, with fewer nodes.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> d(0.2, 1.5);
  for (MapLandmark& l : w.map) l.descriptor = d(rng);
  reloc->setMap(w.map);
  obs = w.observe(truth, 15.0, &ids);
  obs[0].descriptor = std::numeric_limits<double>::quiet_NaN();
  const auto with = reloc->relocalise(obs, w.sensor_offset, nullptr);
  expectCorrect(with, truth, ids, 5);
  EXPECT_LT(with.nodes, without.nodes);
  // A map whose descriptors all disagree with the scan: nothing passes the unary constraint.
  for (MapLandmark& l : w.map) l.descriptor = 5.0;
  reloc->setMap(w.map);
  EXPECT_EQ(reloc->relocalise(obs, w.sensor_offset, nullptr).status,
            RelocalisationStatus::kNotFound);
}

TEST_P(Relocalisers, BadParametersAreNamed) {
  auto reloc = make(GetParam());
  EXPECT_THROW(reloc->configure(params("sensor_range", "-1")), ParameterError);
  EXPECT_THROW(reloc->configure(params("min_pairings", "2")), ParameterError);
  try {
    reloc->configure(params("group_size", "3"));
    FAIL() << "group_size 3 < min_group_pairings 4 accepted";
  } catch (const ParameterError& e) {
    EXPECT_NE(std::string(e.what()).find("group_size"), std::string::npos) << e.what();
  }
}

INSTANTIATE_TEST_SUITE_P(FGCBBAndGCBB, Relocalisers, testing::Values("FGCBB", "GCBB"));

TEST(FGCBB, SplitsManyObservationsIntoCompactGroupsOfAtMostN) {
  const World w = reloc_test::randomMap(300, 120.0, 2.5, 20);
  FGCBB f;
  f.setMap(w.map);
  const Eigen::Vector3d truth(60, 60, 0.2);
  std::vector<LandmarkId> ids;
  const auto obs = w.observe(truth, 15.0, &ids);
  ASSERT_GE(obs.size(), 13u);
  const auto r = f.relocalise(obs, w.sensor_offset, nullptr);
  expectCorrect(r, truth, ids, 10);
  ASSERT_GE(f.lastGroups().size(), 2u);
  for (const auto& g : f.lastGroups()) EXPECT_LE(g.size(), 6u);
  // GCBB keeps one group.
  GCBB g;
  g.setMap(w.map);
  g.relocalise(obs, w.sensor_offset, nullptr);
  EXPECT_EQ(g.lastGroups().size(), 1u);
}

TEST(FGCBB, OverlappingGroupsSeedOneGroupPerObservation) {
  const World w = reloc_test::randomMap(300, 120.0, 2.5, 20);
  FGCBB f;
  f.configure(params("overlapping_groups", "true"));
  f.setMap(w.map);
  const Eigen::Vector3d truth(60, 60, 0.2);
  std::vector<LandmarkId> ids;
  const auto obs = w.observe(truth, 15.0, &ids);
  ASSERT_GE(obs.size(), 13u);
  expectCorrect(f.relocalise(obs, w.sensor_offset, nullptr), truth, ids, 10);
  // More groups than a partition has, none larger than N, no set twice, every observation a seed.
  const auto& groups = f.lastGroups();
  EXPECT_GT(groups.size(), (obs.size() + 5) / 6);
  EXPECT_LE(groups.size(), obs.size());
  std::set<std::vector<int>> sets;
  std::set<int> seeds;
  for (const auto& g : groups) {
    EXPECT_LE(g.size(), 6u);
    seeds.insert(g.front());
    std::vector<int> sorted = g;
    std::sort(sorted.begin(), sorted.end());
    EXPECT_TRUE(sets.insert(sorted).second) << "a set searched twice";
  }
  for (std::size_t i = 0; i < obs.size(); ++i) {
    bool member = false;
    for (const auto& g : groups) member |= std::find(g.begin(), g.end(), int(i)) != g.end();
    EXPECT_TRUE(member) << "observation " << i << " in no group";
  }
}

// group_coverage bounds the overlapping groups: a point seeds one only while it is in fewer groups
// than that, so a scan of m observations gets fewer than m searches, every observation still in
// one, and the same answer.
TEST(FGCBB, GroupCoverageSeedsFewerGroupsAndKeepsEveryObservation) {
  const World w = reloc_test::randomMap(300, 120.0, 2.5, 20);
  const Eigen::Vector3d truth(60, 60, 0.2);
  std::vector<LandmarkId> ids;
  const auto obs = w.observe(truth, 15.0, &ids);
  ASSERT_GE(obs.size(), 13u);
  std::size_t all_seeds = 0;
  for (const std::string coverage : {"0", "1", "2"}) {
    MapParameterSource p = params("overlapping_groups", "true");
    p.set("group_coverage", coverage);
    FGCBB f;
    f.configure(p);
    f.setMap(w.map);
    expectCorrect(f.relocalise(obs, w.sensor_offset, nullptr), truth, ids, 10);
    const auto& groups = f.lastGroups();
    std::vector<int> in_groups(obs.size(), 0);
    for (const auto& g : groups) {
      EXPECT_LE(g.size(), 6u);
      for (const int i : g) ++in_groups[i];
    }
    for (std::size_t i = 0; i < obs.size(); ++i)
      EXPECT_GE(in_groups[i], 1) << "observation " << i << " in no group, coverage " << coverage;
    if (coverage == "0") {
      all_seeds = groups.size();
    } else {
      EXPECT_LT(groups.size(), all_seeds) << "coverage " << coverage;
      // A seed is taken only while it is in fewer than `coverage` groups.
      std::vector<int> before(obs.size(), 0);
      for (const auto& g : groups) {
        EXPECT_LT(before[g.front()], std::stoi(coverage)) << "coverage " << coverage;
        for (const int i : g) ++before[i];
      }
    }
  }
}

// range_sigma / bearing_sigma replace a loose R in the constraints: the observed distances here
// are stretched by 4 %, which a 3 deg bearing noise hides and a 0.2 deg one does not.
TEST_P(Relocalisers, OwnObservationNoiseTightensTheConstraints) {
  const World w = reloc_test::randomMap(200, 120.0, 3.0, 11);
  const Eigen::Vector3d truth(60, 55, 0.4);
  std::vector<LandmarkId> ids;
  auto obs = w.observe(truth, 15.0, &ids, false);
  ASSERT_GE(obs.size(), 6u);
  for (Observation& o : obs) {
    o.z.x() *= 1.04;
    o.R = Eigen::Vector2d(0.3 * 0.3, deg2rad(3.0) * deg2rad(3.0)).asDiagonal();
  }
  auto loose = make(GetParam());
  loose->setMap(w.map);
  const auto a = loose->relocalise(obs, w.sensor_offset, nullptr);
  EXPECT_EQ(a.status, RelocalisationStatus::kFound) << a.reason;
  auto tight = make(GetParam());
  MapParameterSource p;
  p.set("sensor_range", "30");
  p.set("range_sigma", "0.01");
  p.set("bearing_sigma", "0.0035");
  tight->configure(p);
  tight->setMap(w.map);
  const auto b = tight->relocalise(obs, w.sensor_offset, nullptr);
  EXPECT_NE(b.status, RelocalisationStatus::kFound) << "a 4 % stretch passed 1 cm range noise";
  expectNotWrong(b, truth);
}

// A saved map's covariances are absolute: far from where mapping began each tree's is metres wide
// (the vehicle's pose uncertainty then, shared by its neighbours), while their relative geometry is
// exact. Taken as independent, those covariances blunt the binary and joint constraints until the
// search cannot tell the place; landmark_sigma_cap restores them. Set after setMap, too.
TEST_P(Relocalisers, LandmarkSigmaCapRestoresConstraintsBluntedByAbsoluteCovariances) {
  World w = reloc_test::randomMap(200, 120.0, 3.0, 11);
  for (MapLandmark& l : w.map) l.covariance = Eigen::Vector2d(2.5 * 2.5, 1.5 * 1.5).asDiagonal();
  auto loose = make(GetParam());
  loose->setMap(w.map);
  auto capped = make(GetParam());
  capped->setMap(w.map);
  MapParameterSource p;
  p.set("sensor_range", "30");
  p.set("landmark_sigma_cap", "0.3");
  capped->configure(p);
  EXPECT_DOUBLE_EQ(capped->params().landmark_sigma_cap, 0.3);
  EXPECT_DOUBLE_EQ(loose->params().landmark_sigma_cap, 0.0);  // default: the map's covariances
  int loose_found = 0, capped_found = 0, tried = 0;
  for (int k = 0; k < 10; ++k) {
    const Eigen::Vector3d truth(30.0 + 6.0 * k, 25.0 + 7.0 * k, -3.0 + 0.6 * k);
    std::vector<LandmarkId> ids;
    const auto obs = w.observe(truth, 15.0, &ids, true, 100 + k);
    if (obs.size() < 6) continue;
    ++tried;
    SCOPED_TRACE("pose " + std::to_string(k) + ", " + std::to_string(obs.size()) + " obs");
    const auto a = loose->relocalise(obs, w.sensor_offset, nullptr);
    expectNotWrong(a, truth);
    loose_found += a.status == RelocalisationStatus::kFound;
    const auto b = capped->relocalise(obs, w.sensor_offset, nullptr);
    expectNotWrong(b, truth);
    capped_found += b.status == RelocalisationStatus::kFound;
  }
  EXPECT_GE(tried, 6);
  EXPECT_GE(capped_found, 6);                // as with the map's own small covariances
  EXPECT_LT(loose_found, capped_found - 3);  // measured: none found without the cap
  MapParameterSource bad;
  bad.set("landmark_sigma_cap", "-1");
  EXPECT_THROW(capped->configure(bad), std::exception);
}

TEST(FGCBB, DefaultsAreThePapers) {
  FGCBB f;
  EXPECT_EQ(f.name(), "FGCBB");
  EXPECT_EQ(f.params().group_size, 6);
  EXPECT_FALSE(f.params().overlapping_groups);  // the paper's partition
  EXPECT_EQ(f.params().range_sigma, 0.0);       // the observations' own R
  EXPECT_TRUE(f.params().use_locality);
  EXPECT_DOUBLE_EQ(f.params().sensor_range, 16.0);
  GCBB g;
  EXPECT_EQ(g.name(), "GCBB");
  EXPECT_EQ(g.params().group_size, 0);
  EXPECT_FALSE(g.params().use_locality);
}

}  // namespace test_fgcbb
}  // namespace ekf_slam
