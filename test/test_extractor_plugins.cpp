// Feature extractors through pluginlib: names, the unknown-name message, parameter sections and
// TreeExtractor's fallback on the historical top-level names.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <string>

#include "ekf_slam/app/pipeline_builder.h"
#include "ekf_slam/app/yaml_configuration.h"
#include "ekf_slam/core/feature_extraction/beacon_extractor.h"
#include "ekf_slam/core/feature_extraction/tree_feature_extractor.h"
#include "ekf_slam/ros/plugin_loader.h"

namespace test_extractor_plugins {

using namespace ekf_slam;

TEST(ExtractorPlugins, DeclaredNames) {
  const ExtractorLoader loader;
  const auto names = loader.available();
  for (const char* n : {"ekf_slam/TreeExtractor", "ekf_slam/BeaconExtractor"})
    EXPECT_NE(std::find(names.begin(), names.end(), n), names.end()) << n;
  EXPECT_STREQ(ExtractorLoader::kDefault, "ekf_slam/TreeExtractor");
}

TEST(ExtractorPlugins, MisspeltNameListsTheAvailableOnes) {
  const ExtractorLoader loader;
  try {
    loader.create("BeaconExtracter", MapParameterSource());
    FAIL() << "unknown extractor accepted";
  } catch (const UnknownPluginError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("feature extractor 'BeaconExtracter'"), std::string::npos) << what;
    EXPECT_NE(what.find("ekf_slam/BeaconExtractor"), std::string::npos) << what;
    EXPECT_NE(what.find("ekf_slam/TreeExtractor"), std::string::npos) << what;
  }
}

// Through the pipeline builder, as every entry point configures its extractor.
TEST(ExtractorPlugins, TreeExtractorFallsBackOnTopLevelNames) {
  YamlConfiguration c;
  c.setOverride("", "extractor_max_range", "40");
  c.setOverride("", "extractor_range_jump", "2");
  c.setOverride("TreeExtractor", "range_jump", "1.2");
  const PipelineParts parts = buildPipeline(c, PluginlibFactory());
  const auto* tree = dynamic_cast<const TreeFeatureExtractor*>(parts.extractor.get());
  ASSERT_NE(tree, nullptr);
  EXPECT_DOUBLE_EQ(tree->detector().params().max_range, 40.0);  // top level
  EXPECT_DOUBLE_EQ(tree->detector().params().range_jump, 1.2);  // the section wins
  EXPECT_DOUBLE_EQ(tree->detector().params().max_extent, 1.0);  // ACFR's default
}

TEST(ExtractorPlugins, BeaconExtractorReadsItsSectionOnly) {
  YamlConfiguration c;
  c.setOverride("", "extractor", "ekf_slam/BeaconExtractor");
  c.setOverride("", "extractor_max_range", "40");
  c.setOverride("BeaconExtractor", "beacon_radius", "0.05");
  c.setOverride("BeaconExtractor", "max_range", "20");
  const PipelineParts parts = buildPipeline(c, PluginlibFactory());
  const auto* beacon = dynamic_cast<const BeaconExtractor*>(parts.extractor.get());
  ASSERT_NE(beacon, nullptr);
  EXPECT_TRUE(parts.extractor->needsIntensities());
  EXPECT_DOUBLE_EQ(beacon->params().beacon_radius, 0.05);
  EXPECT_DOUBLE_EQ(beacon->params().max_range, 20.0);
  c.setOverride("BeaconExtractor", "max_gap", "-1");
  EXPECT_THROW(buildPipeline(c, PluginlibFactory()), ParameterError);
}

}  // namespace test_extractor_plugins
