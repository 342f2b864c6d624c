// The one pipeline builder (app/pipeline_builder.h), ROS-free: plugin names, sections, the
// unread-key rule, TreeExtractor's fallback, shared sections, and the layers of a YAML
// configuration (defaults under the file, overrides over it).
#include <gtest/gtest.h>

#include <memory>
#include <string>

#include "ekf_slam/app/pipeline_builder.h"
#include "ekf_slam/app/yaml_configuration.h"
#include "ekf_slam/core/association/djnn/djnn.h"
#include "ekf_slam/core/association/nn.h"
#include "ekf_slam/core/association/rrwsc.h"
#include "ekf_slam/core/feature_extraction/beacon_extractor.h"
#include "ekf_slam/core/feature_extraction/tree_feature_extractor.h"
#include "ekf_slam/core/relocalisation/fgcbb.h"
#include "ekf_slam/core/relocalisation/rrwsc_relocaliser.h"

namespace ekf_slam {
namespace test_pipeline_builder {

// The package's plugins constructed directly (what pluginlib does in the shells).
class DirectFactory : public PluginFactory {
 public:
  std::shared_ptr<DataAssociation> associator(const std::string& lookup) const override {
    if (lookup == "ekf_slam/DJNN") return std::make_shared<DJNN>();
    if (lookup == "ekf_slam/NN") return std::make_shared<NN>();
    if (lookup == "ekf_slam/RRWSC") return std::make_shared<RRWSC>();
    throw UnknownPluginError("unknown associator '" + lookup + "'");
  }
  std::shared_ptr<Relocaliser> relocaliser(const std::string& lookup) const override {
    if (lookup == "ekf_slam/FGCBB") return std::make_shared<FGCBB>();
    if (lookup == "ekf_slam/RRWSC") return std::make_shared<RRWSCRelocaliser>();
    throw UnknownPluginError("unknown relocaliser '" + lookup + "'");
  }
  std::shared_ptr<FeatureExtractor> extractor(const std::string& lookup) const override {
    if (lookup == "ekf_slam/TreeExtractor") return std::make_shared<TreeFeatureExtractor>();
    if (lookup == "ekf_slam/BeaconExtractor") return std::make_shared<BeaconExtractor>();
    throw UnknownPluginError("unknown feature extractor '" + lookup + "'");
  }
};

PipelineParts build(const std::string& yaml) {
  return buildPipeline(YamlConfiguration::fromText(yaml, "test.yaml"), DirectFactory());
}

// The ParameterError's text, or "" when it builds.
std::string errorOf(const std::string& yaml) {
  try {
    build(yaml);
  } catch (const ParameterError& e) {
    return e.what();
  }
  return "";
}

TEST(PipelineBuilder, NamesAndDefaults) {
  EXPECT_EQ(pluginLookupName("DJNN"), "ekf_slam/DJNN");
  EXPECT_EQ(pluginLookupName("other_pkg/Mine"), "other_pkg/Mine");
  EXPECT_EQ(pluginShortName("ekf_slam/DJNN"), "DJNN");
  EXPECT_EQ(pluginShortName("DJNN"), "DJNN");

  const PipelineParts p = build("");
  EXPECT_EQ(p.associator_name, "ekf_slam/DJNN");
  EXPECT_EQ(p.extractor_name, "ekf_slam/TreeExtractor");
  EXPECT_EQ(p.relocaliser_name, "ekf_slam/FGCBB");
  ASSERT_NE(dynamic_cast<DJNN*>(p.associator.get()), nullptr);
  ASSERT_NE(dynamic_cast<TreeFeatureExtractor*>(p.extractor.get()), nullptr);
  EXPECT_EQ(p.node.map_frame, "map");
  EXPECT_EQ(p.config.odometry_mode, "twist");
}

TEST(PipelineBuilder, EachPluginReadsItsSection) {
  const PipelineParts p = build(R"(
associator: NN
relocaliser: ekf_slam/FGCBB
extractor: BeaconExtractor
sigma_range: 0.3
map_frame: world
NN:
  individual_probability: 0.9
FGCBB:
  sensor_range: 20.0
BeaconExtractor:
  beacon_radius: 0.05
DJNN:
  not_read: 1   # another associator's section is not looked at
scan_filter_chain:
  - {name: near, type: laser_filters/LaserScanRangeFilter, params: {lower_threshold: 0.5}}
)");
  EXPECT_EQ(p.associator_name, "ekf_slam/NN");
  EXPECT_EQ(p.relocaliser_name, "ekf_slam/FGCBB");
  EXPECT_DOUBLE_EQ(p.config.sigma_range, 0.3);
  EXPECT_EQ(p.node.map_frame, "world");
  EXPECT_DOUBLE_EQ(dynamic_cast<FGCBB&>(*p.relocaliser).params().sensor_range, 20.0);
  EXPECT_DOUBLE_EQ(dynamic_cast<BeaconExtractor&>(*p.extractor).params().beacon_radius, 0.05);
  EXPECT_EQ(p.scan_filter.size(), 1u);
  const std::unique_ptr<SlamPipeline> pipeline = makePipeline(p);
  EXPECT_EQ(&pipeline->associator(), p.associator.get());
  EXPECT_EQ(&pipeline->featureExtractor(), p.extractor.get());
}

// The same rule for every part: a name nobody reads is an error naming it and its nearest
// known neighbour.
TEST(PipelineBuilder, AMisspeltKeyIsTheSameErrorInEverySection) {
  EXPECT_EQ(errorOf("sigma_rnage: 0.3\n"),
            "unknown parameter test.yaml:sigma_rnage (did you mean sigma_range?)");
  EXPECT_EQ(errorOf("DJNN:\n  individual_probabilty: 0.9\n"),
            "unknown parameter test.yaml:DJNN/individual_probabilty (did you mean "
            "individual_probability?)");
  EXPECT_EQ(errorOf("TreeExtractor:\n  range_jmp: 1.0\n"),
            "unknown parameter test.yaml:TreeExtractor/range_jmp (did you mean range_jump?)");
  EXPECT_EQ(errorOf("relocaliser: FGCBB\nFGCBB:\n  sensor_rnage: 20\n"),
            "unknown parameter test.yaml:FGCBB/sensor_rnage (did you mean sensor_range?)");
  EXPECT_EQ(errorOf("scan_filter_chain: []\n"), "");  // the chain is the builder's own key
  // A bad value names its entry too.
  EXPECT_NE(errorOf("DJNN:\n  individual_probability: 2\n").find("DJNN/individual_probability"),
            std::string::npos);
}

TEST(PipelineBuilder, UnknownPluginsAreRefused) {
  EXPECT_THROW(build("associator: DJN\n"), UnknownPluginError);
  EXPECT_THROW(build("relocaliser: FGCB\n"), UnknownPluginError);
  EXPECT_THROW(build("extractor: Trees\n"), UnknownPluginError);
}

TEST(PipelineBuilder, TreeExtractorFallsBackOnItsTopLevelNames) {
  const PipelineParts p = build("extractor_max_range: 40\nTreeExtractor:\n  range_jump: 1.2\n");
  const auto& tree = dynamic_cast<TreeFeatureExtractor&>(*p.extractor);
  EXPECT_DOUBLE_EQ(tree.detector().params().max_range, 40.0);
  EXPECT_DOUBLE_EQ(tree.detector().params().range_jump, 1.2);
}

// The RRWSC associator and the RRWSC relocaliser share the section RRWSC: a key either reads is
// known, one neither reads is not.
TEST(PipelineBuilder, PluginsOfOneNameShareTheirSection) {
  const std::string both = "associator: RRWSC\nrelocaliser: RRWSC\n";
  EXPECT_EQ(errorOf(both + "RRWSC:\n  stale_scans: 5\n  min_inliers: 6\n"), "");
  EXPECT_EQ(errorOf(both + "RRWSC:\n  min_inlier: 6\n"),
            "unknown parameter test.yaml:RRWSC/min_inlier (did you mean min_inliers?)");
  // The RRWSC associator brings the RRWSC relocaliser; without it, its key is nobody's.
  EXPECT_EQ(errorOf("associator: RRWSC\nRRWSC:\n  min_inliers: 6\n"), "");
  EXPECT_NE(errorOf("associator: RRWSC\nrelocaliser: \"\"\nRRWSC:\n  min_inliers: 6\n"), "");
}

// Recovery is on by default (issue 34) with the relocaliser that measured best with no wrong
// fix; `relocaliser: ""` (or an override to "", the tools' --relocaliser "") turns it off.
TEST(PipelineBuilder, RecoveryIsOnByDefaultAndEmptyTurnsItOff) {
  EXPECT_STREQ(kDefaultRelocaliser, "ekf_slam/FGCBB");
  EXPECT_EQ(PipelineConfig().relocaliser, kDefaultRelocaliser);
  const PipelineParts on = build("");
  EXPECT_EQ(on.relocaliser_name, "ekf_slam/FGCBB");
  EXPECT_EQ(on.config.relocaliser, "ekf_slam/FGCBB");
  ASSERT_NE(dynamic_cast<FGCBB*>(on.relocaliser.get()), nullptr);
  EXPECT_EQ(makePipeline(on)->relocaliser(), on.relocaliser.get());

  const PipelineParts off = build("relocaliser: \"\"\n");
  EXPECT_EQ(off.relocaliser_name, "");
  EXPECT_EQ(off.config.relocaliser, "");
  EXPECT_EQ(off.relocaliser, nullptr);
  EXPECT_EQ(makePipeline(off)->relocaliser(), nullptr);

  YamlConfiguration c = YamlConfiguration::fromText("relocaliser: FGCBB\n");
  EXPECT_EQ(relocaliserName(c), "ekf_slam/FGCBB");
  c.setOverride("", "relocaliser", "");
  EXPECT_EQ(relocaliserName(c), "");
  EXPECT_EQ(buildPipeline(c, DirectFactory()).relocaliser, nullptr);
}

// An associator brings its relocaliser unless `relocaliser` is set (also to ""): RRWSC the
// RRWSC relocaliser, every other associator the default.
TEST(PipelineBuilder, AnAssociatorBringsItsRelocaliser) {
  EXPECT_EQ(defaultRelocaliserFor("ekf_slam/RRWSC"), "ekf_slam/RRWSC");
  EXPECT_EQ(defaultRelocaliserFor("RRWSC"), "ekf_slam/RRWSC");
  for (const char* a : {"ekf_slam/DJNN", "ekf_slam/NN", "ekf_slam/JCBB", "ekf_slam/NNJCBB",
                        "ekf_slam/Hungarian", "ekf_slam/truth", "other_pkg/RRWSC"}) {
    EXPECT_EQ(defaultRelocaliserFor(a), kDefaultRelocaliser) << a;
  }
  const PipelineParts rrwsc = build("associator: RRWSC\n");
  EXPECT_EQ(rrwsc.relocaliser_name, "ekf_slam/RRWSC");
  EXPECT_EQ(rrwsc.config.relocaliser, "ekf_slam/RRWSC");
  EXPECT_NE(dynamic_cast<RRWSCRelocaliser*>(rrwsc.relocaliser.get()), nullptr);
  // Set, it holds.
  EXPECT_EQ(build("associator: RRWSC\nrelocaliser: FGCBB\n").relocaliser_name, "ekf_slam/FGCBB");
  EXPECT_EQ(build("associator: RRWSC\nrelocaliser: \"\"\n").relocaliser, nullptr);
  EXPECT_EQ(build("associator: NN\n").relocaliser_name, "ekf_slam/FGCBB");
  // The associator chosen over the file (--associator) brings its own too.
  YamlConfiguration c = YamlConfiguration::fromText("associator: DJNN\n");
  c.setOverride("", "associator", "ekf_slam/RRWSC");
  EXPECT_EQ(relocaliserName(c), "ekf_slam/RRWSC");
  EXPECT_EQ(buildPipeline(c, DirectFactory()).relocaliser_name, "ekf_slam/RRWSC");
}

// The shipped configurations: recovery on (robot.yaml leaves it to the associator, so that
// choosing RRWSC at launch brings RRWSC's; victoria_park.yaml names FGCBB, measured best there).
TEST(PipelineBuilder, TheShippedConfigurationsRecover) {
  const std::string config = std::string(EKF_SLAM_TEST_DATA) + "/../../config/";
  YamlConfiguration robot(config + "robot.yaml");
  EXPECT_EQ(buildPipeline(robot, DirectFactory()).relocaliser_name, "ekf_slam/FGCBB");
  robot.setOverride("", "associator", "ekf_slam/RRWSC");
  EXPECT_EQ(relocaliserName(robot), "ekf_slam/RRWSC");
  YamlConfiguration vp(config + "victoria_park.yaml");
  EXPECT_EQ(buildPipeline(vp, DirectFactory()).relocaliser_name, "ekf_slam/FGCBB");
  vp.setOverride("", "associator", "ekf_slam/RRWSC");
  EXPECT_EQ(relocaliserName(vp), "ekf_slam/FGCBB");
}

TEST(PipelineBuilder, DefaultsLieUnderTheFileAndOverridesOverIt) {
  YamlConfiguration c =
      YamlConfiguration::fromText("sigma_range: 0.3\nDJNN:\n  admit_evidence: 4\n");
  c.setDefault("", "sigma_range", "0.9");       // the file wins
  c.setDefault("", "sigma_bearing", "0.02");    // the file is silent
  c.setDefault("DJNN", "admit_evidence", "9");  // the file wins
  c.setOverride("", "associator", "DJNN");
  c.setOverride("DJNN", "individual_probability", "0.9");
  const PipelineParts p = buildPipeline(c, DirectFactory());
  EXPECT_DOUBLE_EQ(p.config.sigma_range, 0.3);
  EXPECT_DOUBLE_EQ(p.config.sigma_bearing, 0.02);
  const auto& djnn = dynamic_cast<DJNN&>(*p.associator);
  EXPECT_EQ(djnn.params().paper.admit_evidence, 4);
  EXPECT_DOUBLE_EQ(djnn.params().paper.individual_probability, 0.9);
  c.setOverride("", "sigma_range", "0.7");  // an override wins over the file
  EXPECT_DOUBLE_EQ(buildPipeline(c, DirectFactory()).config.sigma_range, 0.7);
  // A default for a key nobody reads is as wrong as the file's own.
  c.setDefault("DJNN", "gatee", "1");
  EXPECT_THROW(buildPipeline(c, DirectFactory()), ParameterError);
}

}  // namespace test_pipeline_builder
}  // namespace ekf_slam
