// Relocalisation from a window of scans (relocalisation_window_scans, docs/relocalisation.md "A
// window of scans"): the carried observations and their covariance, FGCBB on a window whose scans
// are each too sparse alone, and the pipeline's confirmation that must come from scans the held
// fix did not use.
#include <gtest/gtest.h>

#include <cstdio>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "ekf_slam/core/association/djnn/djnn.h"
#include "ekf_slam/core/common/angles.h"
#include "ekf_slam/core/common/pose2d.h"
#include "ekf_slam/core/filter/scan_window.h"
#include "ekf_slam/core/pipeline/slam_pipeline.h"
#include "ekf_slam/core/relocalisation/fgcbb.h"
#include "relocalisation_fixtures.h"
#include "test_files.h"

namespace ekf_slam {
namespace test_recovery_window {

using reloc_test::World;

constexpr double kSpeed = 4.0;  // m/s, one scan per second: 4 m between scans
constexpr double kRange = 6.0;  // the sensor sees so little that one scan has < 5 trees

// Trees along a 300 m road, 2.5-5.5 m apart, up to 5 m either side: an irregular strip.
World road() {
  World w;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> gap(2.5, 5.5), side(-5.0, 5.0);
  for (double x = 0.0; x < 300.0; x += gap(rng)) w.add(x, side(rng));
  return w;
}

TEST(ScanWindow, CarriesPointsAndGrowsTheirCovarianceWithTheOdometry) {
  ScanWindow window(3);
  Observation o;
  o.z = Eigen::Vector2d(5.0, 0.0);
  o.R = Eigen::Vector2d(0.01, 1e-4).asDiagonal();
  window.push(0, Eigen::Vector3d(0.0, 0.0, 0.0), {o});
  const Eigen::Matrix3d Q = Eigen::Vector3d(0.01, 0.01, 0.001).asDiagonal();
  window.addMotion(Eigen::Matrix3d::Identity(), Q);
  window.push(1, Eigen::Vector3d(2.0, 0.0, M_PI / 2), {o});
  window.push(2, Eigen::Vector3d(2.0, 0.0, M_PI / 2), {});  // no observations: not stored
  const std::vector<CarriedScan> scans = window.carried(Eigen::Vector3d(2.0, 0.0, M_PI / 2));
  ASSERT_EQ(scans.size(), 2u);
  EXPECT_EQ(scans[0].scan, 0u);
  EXPECT_EQ(scans[1].scan, 1u);
  // The first scan's base_link seen from the second: 2 m behind, i.e. at (0, 2) turned -90 deg.
  EXPECT_TRUE(scans[0].origin.isApprox(Eigen::Vector3d(0.0, 2.0, -M_PI / 2), 1e-12));
  EXPECT_TRUE(scans[1].origin.isZero(1e-12));
  EXPECT_TRUE(scans[1].origin_covariance.isZero());
  EXPECT_GT(scans[0].origin_covariance.trace(), 0.02);
  // A point 5 m ahead of the first base_link is 3 m to the right of the second.
  Eigen::Vector2d p(5.0, 0.0);
  Eigen::Matrix2d C = Eigen::Vector2d(0.01, 0.01).asDiagonal();
  carryPoint(scans[0].origin, scans[0].origin_covariance, &p, &C);
  EXPECT_TRUE(p.isApprox(Eigen::Vector2d(0.0, -3.0), 1e-12));
  EXPECT_GT(C.trace(), 0.02 + 0.02);  // its own plus the odometry's
  // Older than the window: dropped.
  window.push(3, Eigen::Vector3d(3.0, 1.0, M_PI / 2), {o});
  window.push(4, Eigen::Vector3d(4.0, 1.0, M_PI / 2), {o});
  EXPECT_EQ(window.carried(Eigen::Vector3d(4.0, 1.0, M_PI / 2)).front().scan, 1u);
}

TEST(ScanWindow, FgcbbFindsThePoseFromScansEachTooSparseAlone) {
  const World w = road();
  FGCBB fgcbb;
  fgcbb.setMap(w.map);
  ScanWindow window(4);
  std::vector<Eigen::Vector3d> poses;
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector3d pose(60.0 + kSpeed * k, 0.5, 0.02 * k);
    const std::vector<Observation> obs = w.observe(pose, kRange, nullptr, true, 11 + k);
    ASSERT_LT(obs.size(), 5u) << "scan " << k << " is not sparse";
    EXPECT_NE(fgcbb.relocalise(obs, w.sensor_offset, nullptr).status, RelocalisationStatus::kFound);
    if (k > 0) window.addMotion(Eigen::Matrix3d::Identity(), 1e-4 * Eigen::Matrix3d::Identity());
    window.push(static_cast<std::uint32_t>(k), pose, obs);
    poses.push_back(pose);
  }
  const std::vector<CarriedScan> scans = window.carried(poses.back());
  const RelocalisationResult r = fgcbb.relocaliseWindow(scans, w.sensor_offset, nullptr);
  ASSERT_EQ(r.status, RelocalisationStatus::kFound) << r.reason;
  EXPECT_LT(reloc_test::positionError(r.pose, poses.back()), 0.3);
  EXPECT_LT(reloc_test::headingError(r.pose, poses.back()), 0.02);
  std::size_t n = 0;
  for (const CarriedScan& c : scans) n += c.observations.size();
  EXPECT_EQ(r.landmark.size(), n);
  EXPECT_GE(r.hypothesis_size, 5);
}

// Drives the road with a loaded map and an unknown pose: one second of odometry, then a scan.
class RoadDrive {
 public:
  RoadDrive(int window, int confirmations, std::shared_ptr<Relocaliser> relocaliser = nullptr)
      : world_(road()), truth_(40.0, 0.5, 0.0) {
    PipelineConfig config;
    config.initial_pose = Eigen::Vector3d(150.0, 20.0, 1.0);  // far off: the pose is unknown
    config.sigma_range = reloc_test::kSigmaRange;
    config.sigma_bearing = reloc_test::kSigmaBearing;
    config.max_observation_range = kRange;
    config.lost_field_of_view = 2.0 * M_PI;
    config.relocalisation_confirmations = confirmations;
    config.relocalisation_window_scans = window;
    auto djnn = std::make_shared<DJNN>();
    MapParameterSource djnn_params;
    djnn_params.set("sensor_range", std::to_string(kRange));
    djnn_params.set("field_of_view", "6.2831");
    djnn->configure(djnn_params);
    pipeline_ = std::make_unique<SlamPipeline>(config, djnn);
    pipeline_->setSensorOffset(world_.sensor_offset);
    pipeline_->setRelocaliser(relocaliser ? relocaliser : std::make_shared<FGCBB>());
    const std::string path = dir_.file("map.txt");
    std::FILE* f = std::fopen(path.c_str(), "w");
    std::fprintf(f, "ekf_slam_map 1\n");
    for (const MapLandmark& l : world_.map) {
      std::fprintf(f, "%lld %.17g %.17g %.17g 0 %.17g nan 5\n", static_cast<long long>(l.id),
                   l.position.x(), l.position.y(), l.covariance(0, 0), l.covariance(1, 1));
    }
    std::fclose(f);
    pipeline_->loadMap(path, /*reset_pose=*/true, /*unknown_pose=*/true);
  }

  ScanReport step() {
    const TwistModel exact;
    for (int s = 0; s < 40; ++s) {
      OdometryInput o;
      o.stamp = t_;
      o.twist = Eigen::Vector2d(kSpeed, 0.0);
      pipeline_->addOdometry(o);
      truth_ = exact.predict(truth_, {kSpeed, 0.0}, 0.025);
      t_ += 0.025;
    }
    return pipeline_->processObservations(t_,
                                          world_.observe(truth_, kRange, nullptr, true, seed_++));
  }
  double error() const { return (pipeline_->pose().head<2>() - truth_.head<2>()).norm(); }
  SlamPipeline& pipeline() { return *pipeline_; }
  const Eigen::Vector3d& truth() const { return truth_; }

 private:
  test_files::TempDir dir_;
  World world_;
  Eigen::Vector3d truth_;
  double t_ = 0.0;
  unsigned seed_ = 1;
  std::unique_ptr<SlamPipeline> pipeline_;
};

TEST(RecoveryWindow, ScansEachTooSparseAloneGiveAConfirmedFix) {
  {
    RoadDrive one_scan(/*window=*/1, /*confirmations=*/1);
    for (int k = 0; k < 15; ++k) {
      const ScanReport r = one_scan.step();
      ASSERT_LT(r.observations.size(), 5u) << "scan " << k << " is not sparse";
      EXPECT_FALSE(r.relocalised);
    }
    EXPECT_TRUE(one_scan.pipeline().lost());
  }
  RoadDrive d(/*window=*/4, /*confirmations=*/1);
  int fixed_at = -1;
  for (int k = 0; k < 15 && fixed_at < 0; ++k) {
    if (d.step().relocalised) fixed_at = k;
  }
  ASSERT_GE(fixed_at, 0) << "never relocalised";
  // A first fix held, then one from a window that shares no scan with it.
  EXPECT_GE(fixed_at, 4);
  EXPECT_GE(d.pipeline().counters().relocalisations_unconfirmed, 1u);
  EXPECT_EQ(d.pipeline().counters().relocalisations, 1u);
  EXPECT_LT(d.error(), 0.5);
  EXPECT_LT(reloc_test::headingError(d.pipeline().pose(), d.truth()), 0.02);
  // The pose is sane and tracking goes on in the loaded map.
  const Eigen::Vector3d e(d.pipeline().pose().x() - d.truth().x(),
                          d.pipeline().pose().y() - d.truth().y(),
                          wrapAngle(d.pipeline().pose().z() - d.truth().z()));
  EXPECT_LT(e.dot(d.pipeline().poseCovariance().ldlt().solve(e)), 16.3);
  for (int k = 0; k < 10; ++k) d.step();
  EXPECT_FALSE(d.pipeline().lost());
  EXPECT_LT(d.error(), 0.5);
}

// Found whenever the window holds scan `chance` (a chance alignment in that scan's data), 30 m
// off; or, with `always`, the truth at every call.
class FromOneScan : public Relocaliser {
 public:
  FromOneScan(const Eigen::Vector3d* truth, std::uint32_t chance, bool always = false)
      : truth_(truth), chance_(chance), always_(always) {}
  void configure(const ParameterSource&) override {}
  std::string name() const override { return "FromOneScan"; }
  void setMap(const std::vector<MapLandmark>&) override {}
  RelocalisationResult relocalise(const std::vector<Observation>& obs, const Eigen::Vector3d&,
                                  const PosePrior*) override {
    RelocalisationResult r;
    r.landmark.assign(obs.size(), kNoLandmark);
    return r;
  }
  RelocalisationResult relocaliseWindow(const std::vector<CarriedScan>& scans,
                                        const Eigen::Vector3d&, const PosePrior*) override {
    ++calls;
    RelocalisationResult r;
    for (const CarriedScan& s : scans) {
      r.landmark.insert(r.landmark.end(), s.observations.size(), kNoLandmark);
      if (s.scan == chance_) r.status = RelocalisationStatus::kFound;
    }
    if (always_) r.status = RelocalisationStatus::kFound;
    r.pose = composePose(*truth_, always_ ? Eigen::Vector3d::Zero() : Eigen::Vector3d(30, -20, 0));
    r.covariance = 1e-4 * Eigen::Matrix3d::Identity();
    return r;
  }
  int calls = 0;

 private:
  const Eigen::Vector3d* truth_;
  std::uint32_t chance_;
  bool always_;
};

TEST(RecoveryWindow, AWindowSharingTheHeldFixsScansDoesNotConfirmIt) {
  // Scan 2 aligns by chance; the windows of scans 2, 3 and 4 all contain it and agree with each
  // other (the same data), yet none may confirm another.
  std::shared_ptr<FromOneScan> reloc;
  auto d = std::make_unique<RoadDrive>(3, 1, nullptr);
  reloc = std::make_shared<FromOneScan>(&d->truth(), 2u);
  d->pipeline().setRelocaliser(reloc);
  d->pipeline().requestRelocalisation();  // the map goes to the new relocaliser
  int held = 0;
  for (int k = 0; k < 10; ++k) {
    const ScanReport r = d->step();
    EXPECT_FALSE(r.relocalised) << "scan " << r.scan << ": " << r.lost_reason;
    held += r.relocalisation.status == RelocalisationStatus::kFound;
  }
  EXPECT_EQ(held, 3);
  EXPECT_TRUE(d->pipeline().lost());
  EXPECT_EQ(d->pipeline().counters().relocalisations, 0u);
  EXPECT_GT(d->error(), 20.0 - 1e-9);  // still the dead-reckoned estimate, never the chance fix
}

TEST(RecoveryWindow, ADisjointAgreeingWindowConfirms) {
  auto d = std::make_unique<RoadDrive>(3, 1, nullptr);
  auto reloc = std::make_shared<FromOneScan>(&d->truth(), 0u, /*always=*/true);
  d->pipeline().setRelocaliser(reloc);
  d->pipeline().requestRelocalisation();
  // Held at the first scan; its window is that scan alone, so the first window without it (the
  // fourth scan's: the second to the fourth) confirms.
  std::vector<bool> fixed;
  for (int k = 0; k < 4; ++k) fixed.push_back(d->step().relocalised);
  EXPECT_EQ(fixed, (std::vector<bool>{false, false, false, true}));
  EXPECT_LT(d->error(), 0.5);
}

}  // namespace test_recovery_window
}  // namespace ekf_slam
