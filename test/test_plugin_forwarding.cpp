// Wrappers of the plugin interfaces forward every hook (issue 35: the offline runner's wrapper
// once dropped DataAssociation::poseCorrected, and DJNN then behaved differently offline).
//
// Each family has one forwarding base (ForwardingAssociator, ForwardingRelocaliser,
// ForwardingFeatureExtractor) that every wrapper derives from. Here a recording fake is wrapped
// and every hook is called through the wrapper: each must reach the fake with its arguments and
// bring back its result. The interface headers are read as well: a virtual added to a base class
// without a forward (or without a case here) fails the count.
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <memory>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "association_fixtures.h"
#include "ekf_slam/core/association/data_association.h"
#include "ekf_slam/core/feature_extraction/feature_extractor.h"
#include "ekf_slam/core/relocalisation/relocaliser.h"

namespace ekf_slam {
namespace test_plugin_forwarding {

// The body of `class NAME ...{ ... };` in a header of the source tree.
std::string classBody(const std::string& header, const std::string& name) {
  std::ifstream in(std::string(EKF_SLAM_SOURCE_DIR) + "/include/ekf_slam/" + header);
  std::stringstream text;
  text << in.rdbuf();
  const std::string s = text.str();
  const std::size_t start = s.find("\nclass " + name + " ");
  if (start == std::string::npos) return "";
  const std::size_t end = s.find("\n};", start);
  return s.substr(start, end - start);
}

std::size_t count(const std::string& text, const std::string& pattern) {
  const std::regex re(pattern);
  return std::distance(std::sregex_iterator(text.begin(), text.end(), re), std::sregex_iterator());
}

// Virtual member functions a base class declares (its destructor aside) and the overrides its
// forwarding class has: every one must be forwarded, and exercised by the test below.
void expectEveryVirtualForwarded(const std::string& header, const std::string& base,
                                 const std::string& forwarding, std::size_t hooks_tested) {
  const std::string b = classBody(header, base), f = classBody(header, forwarding);
  ASSERT_FALSE(b.empty()) << base << " not found in " << header;
  ASSERT_FALSE(f.empty()) << forwarding << " not found in " << header;
  const std::size_t virtuals = count(b, R"(\bvirtual\s+[^~])");
  EXPECT_EQ(count(f, R"(\boverride\b)"), virtuals)
      << forwarding << " must forward every virtual of " << base;
  EXPECT_EQ(hooks_tested, virtuals) << "a virtual of " << base << " is not exercised here";
}

// --- DataAssociation -----------------------------------------------------------------------------

class RecordingAssociator : public DataAssociation {
 public:
  std::vector<std::string> calls;
  void configure(const ParameterSource& params) override {
    double v = 0.0;
    params.get("gate", &v);
    calls.push_back("configure " + std::to_string(v));
  }
  std::string name() const override { return "Recording"; }
  AssociationResult associate(const AssociationContext& context) override {
    calls.push_back("associate " + std::to_string(context.numObservations()));
    AssociationResult r;
    r.resize(context.numObservations());
    r.decision[0] = Decision::kNew;
    return r;
  }
  void landmarkAdded(int obs, LandmarkId id) override {
    calls.push_back("landmarkAdded " + std::to_string(obs) + " " + std::to_string(id));
  }
  void landmarkLoaded(LandmarkId id, std::uint32_t times) override {
    calls.push_back("landmarkLoaded " + std::to_string(id) + " " + std::to_string(times));
  }
  bool landmarkFromLostScans(LandmarkId id, const Eigen::Matrix2d&,
                             const std::vector<LostLook>& looks) override {
    calls.push_back("landmarkFromLostScans " + std::to_string(id) + " " +
                    std::to_string(looks.size()));
    return false;
  }
  bool landmarkOverLostScans(LandmarkId id, const Eigen::Matrix2d&,
                             const std::vector<LostLook>& looks) override {
    calls.push_back("landmarkOverLostScans " + std::to_string(id) + " " +
                    std::to_string(looks.size()));
    return false;
  }
  void poseCorrected(const Eigen::Vector3d& prior, const Eigen::Vector3d& posterior) override {
    calls.push_back("poseCorrected " + std::to_string(prior.x()) + " " +
                    std::to_string(posterior.x()));
  }
  void reset() override { calls.push_back("reset"); }
  int evidence(LandmarkId id) const override { return static_cast<int>(id) + 1; }
  std::vector<TentativeFeature> tentativeFeatures() const override {
    return {{Eigen::Vector2d(1.0, 2.0), 3}};
  }
};

TEST(PluginForwarding, AssociatorWrapperForwardsEveryHook) {
  expectEveryVirtualForwarded("core/association/data_association.h", "DataAssociation",
                              "ForwardingAssociator", 11);
  auto inner = std::make_shared<RecordingAssociator>();
  ForwardingAssociator wrapper(inner);
  wrapper.configure(MapParameterSource(std::map<std::string, std::string>{{"gate", "7"}}));
  EXPECT_EQ(wrapper.name(), "Recording");
  assoc_test::Scene scene;
  scene.addLandmark({10.0, 2.0});
  scene.build();
  scene.observePoint({5.0, -5.0});
  const AssociationResult r = wrapper.associate(scene.context());
  ASSERT_EQ(r.decision.size(), 1u);
  EXPECT_EQ(r.decision[0], Decision::kNew);
  wrapper.landmarkAdded(0, 42);
  wrapper.landmarkLoaded(43, 5);
  EXPECT_FALSE(
      wrapper.landmarkFromLostScans(44, Eigen::Matrix2d::Identity(), std::vector<LostLook>(3)));
  EXPECT_FALSE(
      wrapper.landmarkOverLostScans(45, Eigen::Matrix2d::Identity(), std::vector<LostLook>(2)));
  wrapper.poseCorrected(Eigen::Vector3d(1.0, 0.0, 0.0), Eigen::Vector3d(2.0, 0.0, 0.0));
  wrapper.reset();
  EXPECT_EQ(wrapper.evidence(9), 10);
  ASSERT_EQ(wrapper.tentativeFeatures().size(), 1u);
  EXPECT_EQ(wrapper.tentativeFeatures()[0].evidence, 3);
  EXPECT_EQ(inner->calls,
            (std::vector<std::string>{"configure 7.000000", "associate 1", "landmarkAdded 0 42",
                                      "landmarkLoaded 43 5", "landmarkFromLostScans 44 3",
                                      "landmarkOverLostScans 45 2",
                                      "poseCorrected 1.000000 2.000000", "reset"}));
}

// --- Relocaliser ---------------------------------------------------------------------------------

class RecordingRelocaliser : public Relocaliser {
 public:
  std::vector<std::string> calls;
  void configure(const ParameterSource&) override { calls.push_back("configure"); }
  std::string name() const override { return "Recording"; }
  void setMap(const std::vector<MapLandmark>& map) override {
    calls.push_back("setMap " + std::to_string(map.size()));
  }
  RelocalisationResult relocalise(const std::vector<Observation>& observations,
                                  const Eigen::Vector3d& offset, const PosePrior* prior) override {
    calls.push_back("relocalise " + std::to_string(observations.size()) + " " +
                    std::to_string(offset.x()) + (prior ? " prior" : ""));
    RelocalisationResult r;
    r.status = RelocalisationStatus::kFound;
    r.hypothesis_size = 4;
    return r;
  }
  RelocalisationResult relocaliseWindow(const std::vector<CarriedScan>& scans,
                                        const Eigen::Vector3d&, const PosePrior*) override {
    calls.push_back("relocaliseWindow " + std::to_string(scans.size()));
    RelocalisationResult r;
    r.status = RelocalisationStatus::kAmbiguous;
    return r;
  }
};

TEST(PluginForwarding, RelocaliserWrapperForwardsEveryHook) {
  expectEveryVirtualForwarded("core/relocalisation/relocaliser.h", "Relocaliser",
                              "ForwardingRelocaliser", 5);
  auto inner = std::make_shared<RecordingRelocaliser>();
  ForwardingRelocaliser wrapper(inner);
  wrapper.configure(MapParameterSource());
  EXPECT_EQ(wrapper.name(), "Recording");
  wrapper.setMap(std::vector<MapLandmark>(3));
  const PosePrior prior;
  EXPECT_EQ(wrapper.relocalise(std::vector<Observation>(2), Eigen::Vector3d(0.5, 0, 0), &prior)
                .hypothesis_size,
            4);
  EXPECT_EQ(wrapper.relocaliseWindow(std::vector<CarriedScan>(2), Eigen::Vector3d::Zero(), nullptr)
                .status,
            RelocalisationStatus::kAmbiguous);
  EXPECT_EQ(inner->calls,
            (std::vector<std::string>{"configure", "setMap 3", "relocalise 2 0.500000 prior",
                                      "relocaliseWindow 2"}));
}

// --- FeatureExtractor ----------------------------------------------------------------------------

class RecordingExtractor : public FeatureExtractor {
 public:
  mutable std::vector<std::string> calls;
  void configure(const ParameterSource&) override { calls.push_back("configure"); }
  std::string name() const override { return "Recording"; }
  bool needsIntensities() const override { return true; }
  double featureRadius() const override { return 0.25; }
  double thinnestFeatureRadius() const override { return 0.05; }
  void checkScan(const LaserScanData& scan) const override {
    calls.push_back("checkScan " + std::to_string(scan.ranges.size()));
  }
  std::vector<Observation> extract(const LaserScanData& scan) const override {
    calls.push_back("extract " + std::to_string(scan.ranges.size()));
    return std::vector<Observation>(2);
  }
};

TEST(PluginForwarding, ExtractorWrapperForwardsEveryHook) {
  expectEveryVirtualForwarded("core/feature_extraction/feature_extractor.h", "FeatureExtractor",
                              "ForwardingFeatureExtractor", 7);
  auto inner = std::make_shared<RecordingExtractor>();
  ForwardingFeatureExtractor wrapper(inner);
  wrapper.configure(MapParameterSource());
  EXPECT_EQ(wrapper.name(), "Recording");
  EXPECT_TRUE(wrapper.needsIntensities());
  EXPECT_EQ(wrapper.featureRadius(), 0.25);
  EXPECT_EQ(wrapper.thinnestFeatureRadius(), 0.05);
  LaserScanData scan;
  scan.ranges.assign(3, 1.0f);
  wrapper.checkScan(scan);
  EXPECT_EQ(wrapper.extract(scan).size(), 2u);
  EXPECT_EQ(inner->calls, (std::vector<std::string>{"configure", "checkScan 3", "extract 3"}));
}

}  // namespace test_plugin_forwarding
}  // namespace ekf_slam
