// The RRW&SC relocaliser loads through pluginlib by name (needs the devel space's environment,
// which ctest provides; no master) and relocalises a small scan.
#include <gtest/gtest.h>

#include <algorithm>

#include <pluginlib/class_loader.hpp>

#include "ekf_slam/core/relocalisation/relocaliser.h"
#include "rrwsc_fixtures.h"

namespace ekf_slam {
namespace test_rrwsc_relocaliser_plugin {

TEST(RelocalisationPlugins, RrwscLoadsByNameAndRelocalises) {
  pluginlib::ClassLoader<Relocaliser> loader("ekf_slam", "ekf_slam::Relocaliser");
  const auto names = loader.getDeclaredClasses();
  EXPECT_NE(std::find(names.begin(), names.end(), "ekf_slam/RRWSC"), names.end());
  boost::shared_ptr<Relocaliser> reloc = loader.createInstance("ekf_slam/RRWSC");
  ASSERT_TRUE(reloc);
  reloc->configure(MapParameterSource());
  EXPECT_EQ(reloc->name(), "RRWSC");
  const auto points = rrwsc_test::randomMap(20, 50.0, 8.0, 1);
  std::vector<MapLandmark> map;
  for (std::size_t k = 0; k < points.size(); ++k) {
    MapLandmark l;
    l.id = static_cast<LandmarkId>(k);
    l.position = points[k];
    l.covariance = 0.01 * Eigen::Matrix2d::Identity();
    map.push_back(l);
  }
  reloc->setMap(map);
  const Eigen::Vector3d pose(5.0, -3.0, 1.0);
  const auto scan = rrwsc_test::scanOf(points, pose, {0.05, 0.01}, 1);
  const RelocalisationResult r =
      reloc->relocalise(scan.observations, Eigen::Vector3d::Zero(), nullptr);
  ASSERT_EQ(r.status, RelocalisationStatus::kFound) << r.reason;
  EXPECT_LT((r.pose - pose).norm(), 0.2);
}

}  // namespace test_rrwsc_relocaliser_plugin
}  // namespace ekf_slam
