// Every associator and relocaliser loads through pluginlib by name (one PluginLoader for both
// families; needs the devel space's environment, which ctest provides; no master), a misspelt
// name lists the available ones, bad parameters from YAML name the parameter. RosParameterSource is
// tested under rostest (test_ros_parameter_source).
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "ekf_slam/app/association_problem.h"
#include "ekf_slam/app/yaml_parameter_source.h"
#include "ekf_slam/core/association/djnn/djnn.h"
#include "ekf_slam/core/relocalisation/fgcbb.h"
#include "ekf_slam/ros/plugin_loader.h"

namespace ekf_slam {
namespace test_plugins {

const std::vector<std::string> kNames = {"ekf_slam/DJNN", "ekf_slam/Hungarian", "ekf_slam/JCBB",
                                         "ekf_slam/NN",   "ekf_slam/NNJCBB",    "ekf_slam/RRWSC"};

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(AssociatorLoader, DeclaresEveryAssociator) {
  AssociatorLoader loader;
  EXPECT_EQ(loader.available(), kNames);
}

TEST(AssociatorLoader, EveryPluginLoadsAndAssociatesATinyProblem) {
  const auto problem = readAssociationProblem(EKF_SLAM_TEST_DATA "/clear.json");
  AssociatorLoader loader;
  for (const auto& name : kNames) {
    SCOPED_TRACE(name);
    const auto assoc = loader.create(name, MapParameterSource());
    ASSERT_TRUE(assoc);
    EXPECT_EQ("ekf_slam/" + assoc->name(), name);
    const auto replay = replayAssociation(problem, *assoc);
    // Observation 1 is clutter; the others see landmarks 1, 2 and 0.
    EXPECT_EQ(replay.landmark, (std::vector<int>{1, -1, 2, 0}));
  }
}

TEST(AssociatorLoader, BareAlgorithmNameGetsThePackagePrefix) {
  AssociatorLoader loader;
  const auto assoc = loader.create("NNJCBB", MapParameterSource());
  EXPECT_EQ(assoc->name(), "NNJCBB");
  EXPECT_EQ(AssociatorLoader::lookupName("DJNN"), "ekf_slam/DJNN");
  EXPECT_EQ(AssociatorLoader::lookupName("other_pkg/X"), "other_pkg/X");
}

TEST(AssociatorLoader, MisspeltNameListsTheAvailableOnes) {
  AssociatorLoader loader;
  try {
    loader.create("ekf_slam/DJN", MapParameterSource());
    FAIL() << "ekf_slam/DJN was created";
  } catch (const UnknownAssociatorError& e) {
    const std::string what = e.what();
    EXPECT_TRUE(contains(what, "'ekf_slam/DJN'")) << what;
    for (const auto& name : kNames) EXPECT_TRUE(contains(what, name)) << what;
  }
}

TEST(AssociatorLoader, ConfiguresFromTheParameterSource) {
  AssociatorLoader loader;
  const auto src = YamlParameterSource::fromString(
      "individual_probability: 0.9\nDJNN:\n  sensor_range: 42.0\n  admit_evidence: 3\n", "DJNN");
  const auto assoc = loader.create("ekf_slam/DJNN", src);
  // The plugin is the same class as the core's DJNN (one ekf_slam_core shared by both).
  const auto* djnn = dynamic_cast<const DJNN*>(assoc.get());
  ASSERT_NE(djnn, nullptr);
  EXPECT_DOUBLE_EQ(djnn->params().paper.sensor.max_range, 42.0);
  EXPECT_EQ(djnn->params().paper.admit_evidence, 3);
  EXPECT_DOUBLE_EQ(djnn->params().paper.individual_probability, 0.9);
}

TEST(AssociatorLoader, BadYamlValueNamesTheParameter) {
  AssociatorLoader loader;
  const auto out_of_range =
      YamlParameterSource::fromString("JCBB:\n  joint_probability: 1.5\n", "JCBB", "p.yaml");
  try {
    loader.create("ekf_slam/JCBB", out_of_range);
    FAIL() << "joint_probability = 1.5 accepted";
  } catch (const ParameterError& e) {
    EXPECT_TRUE(contains(e.what(), "p.yaml:JCBB/joint_probability")) << e.what();
  }
  const auto wrong_type =
      YamlParameterSource::fromString("individual_probability: high\n", "NN", "p.yaml");
  try {
    loader.create("ekf_slam/NN", wrong_type);
    FAIL() << "individual_probability = high accepted";
  } catch (const ParameterError& e) {
    EXPECT_TRUE(contains(e.what(), "p.yaml:individual_probability")) << e.what();
  }
}

TEST(AssociatorLoader, InstanceOutlivesTheLoader) {
  std::shared_ptr<DataAssociation> assoc;
  {
    AssociatorLoader loader;
    assoc = loader.create("ekf_slam/JCBB", MapParameterSource());
  }
  // The library must still be loaded: the vtable and code live in it.
  const auto problem = readAssociationProblem(EKF_SLAM_TEST_DATA "/clear.json");
  EXPECT_EQ(replayAssociation(problem, *assoc).landmark, (std::vector<int>{1, -1, 2, 0}));
  EXPECT_EQ(assoc->name(), "JCBB");
  assoc.reset();
}

// --- relocalisers (the same loader, the other family) -------------------------------------------

const std::vector<std::string> kRelocalisers = {"ekf_slam/FGCBB", "ekf_slam/GCBB",
                                                "ekf_slam/RRWSC"};

TEST(RelocaliserLoader, DeclaresEveryRelocaliserAndOnlyThem) {
  RelocaliserLoader loader;
  // Other families' plugins (the associators: DJNN, NN, ...) are not relocalisers; RRWSC is in
  // both families, with a class of each.
  for (const auto& name : kRelocalisers) {
    const auto a = loader.available();
    EXPECT_NE(std::find(a.begin(), a.end(), name), a.end()) << name;
  }
  for (const auto& name : loader.available()) {
    EXPECT_NE(std::find(kRelocalisers.begin(), kRelocalisers.end(), name), kRelocalisers.end())
        << name;
  }
  EXPECT_STREQ(RelocaliserLoader::kDefault, "ekf_slam/FGCBB");
}

TEST(RelocaliserLoader, LoadsByFullOrBareNameAndRelocalises) {
  RelocaliserLoader loader;
  for (const auto& name : {std::string("ekf_slam/FGCBB"), std::string("GCBB")}) {
    SCOPED_TRACE(name);
    const auto reloc = loader.create(name, MapParameterSource());
    ASSERT_TRUE(reloc);
    EXPECT_EQ("ekf_slam/" + reloc->name(), RelocaliserLoader::lookupName(name));
    // Five landmarks seen from the origin: the pose comes back.
    std::vector<MapLandmark> map;
    std::vector<Observation> obs;
    const std::vector<Eigen::Vector2d> pts = {{5, 1}, {8, -3}, {3, 6}, {11, 4}, {6, -7}, {2, -2}};
    for (std::size_t i = 0; i < pts.size(); ++i) {
      MapLandmark l;
      l.id = static_cast<LandmarkId>(10 + i);
      l.position = pts[i] + Eigen::Vector2d(100, 50);
      l.covariance = Eigen::Matrix2d::Identity() * 0.01;
      map.push_back(l);
      Observation o;
      o.z = Eigen::Vector2d(pts[i].norm(), std::atan2(pts[i].y(), pts[i].x()));
      o.R = Eigen::Vector2d(0.01, 1e-4).asDiagonal();
      obs.push_back(o);
    }
    reloc->setMap(map);
    const auto r = reloc->relocalise(obs, Eigen::Vector3d::Zero(), nullptr);
    ASSERT_EQ(r.status, RelocalisationStatus::kFound) << r.reason;
    EXPECT_NEAR(r.pose.x(), 100.0, 1e-3);
    EXPECT_NEAR(r.pose.y(), 50.0, 1e-3);
    EXPECT_EQ(r.landmark.front(), 10);
  }
}

TEST(RelocaliserLoader, MisspeltNameListsTheAvailableOnes) {
  RelocaliserLoader loader;
  try {
    loader.create("ekf_slam/FGCB", MapParameterSource());
    FAIL() << "ekf_slam/FGCB was created";
  } catch (const UnknownRelocaliserError& e) {
    const std::string what = e.what();
    EXPECT_TRUE(contains(what, "unknown relocaliser 'ekf_slam/FGCB'")) << what;
    for (const auto& name : kRelocalisers) EXPECT_TRUE(contains(what, name)) << what;
    EXPECT_FALSE(contains(what, "ekf_slam/DJNN")) << what;
  }
  // An associator's name is no relocaliser.
  EXPECT_THROW(loader.create("DJNN", MapParameterSource()), UnknownRelocaliserError);
}

TEST(RelocaliserLoader, ConfiguresFromItsSectionAndNamesBadParameters) {
  RelocaliserLoader loader;
  const auto src = YamlParameterSource::fromString("FGCBB:\n  group_size: 8\n  sensor_range: 20\n",
                                                   "FGCBB", "p.yaml");
  const auto reloc = loader.create("FGCBB", src);
  const auto* f = dynamic_cast<const FGCBB*>(reloc.get());
  ASSERT_NE(f, nullptr);
  EXPECT_EQ(f->params().group_size, 8);
  EXPECT_DOUBLE_EQ(f->params().sensor_range, 20.0);
  const auto bad =
      YamlParameterSource::fromString("FGCBB:\n  joint_probability: 2\n", "FGCBB", "p.yaml");
  try {
    loader.create("FGCBB", bad);
    FAIL() << "joint_probability = 2 accepted";
  } catch (const ParameterError& e) {
    EXPECT_TRUE(contains(e.what(), "p.yaml:FGCBB/joint_probability")) << e.what();
  }
}

// --- YamlParameterSource -------------------------------------------------------------------------

TEST(YamlParameterSource, SectionOverridesTopLevel) {
  const auto src = YamlParameterSource::fromString(
      "a: 1.5\nb: 2\nflag: true\nname: valid\nDJNN:\n  b: 7\nJCBB:\n  a: 9\n", "DJNN", "f.yaml");
  double a = 0, b = 0;
  int bi = 0;
  bool flag = false;
  std::string name;
  ASSERT_TRUE(src.get("a", &a));
  EXPECT_DOUBLE_EQ(a, 1.5);  // JCBB's section is not read
  ASSERT_TRUE(src.get("b", &b));
  EXPECT_DOUBLE_EQ(b, 7.0);
  ASSERT_TRUE(src.get("b", &bi));
  EXPECT_EQ(bi, 7);
  ASSERT_TRUE(src.get("flag", &flag));
  EXPECT_TRUE(flag);
  ASSERT_TRUE(src.get("name", &name));
  EXPECT_EQ(name, "valid");
  EXPECT_FALSE(src.get("missing", &a));
  EXPECT_EQ(src.qualify("a"), "f.yaml:a");
  EXPECT_EQ(src.qualify("b"), "f.yaml:DJNN/b");
}

TEST(YamlParameterSource, WrongTypesThrowParameterError) {
  const auto src = YamlParameterSource::fromString("x: 2.5\ns: abc\nl: [1, 2]\nn:\n", "", "f.yaml");
  int i = 0;
  double d = 0;
  bool b = false;
  EXPECT_THROW(src.get("x", &i), ParameterError);
  EXPECT_THROW(src.get("s", &d), ParameterError);
  EXPECT_THROW(src.get("s", &b), ParameterError);
  try {
    src.get("l", &d);
    FAIL();
  } catch (const ParameterError& e) {
    EXPECT_TRUE(contains(e.what(), "f.yaml:l")) << e.what();
    EXPECT_TRUE(contains(e.what(), "list")) << e.what();
  }
  EXPECT_THROW(src.get("n", &d), ParameterError);
}

TEST(YamlParameterSource, BadFilesAreReported) {
  EXPECT_THROW(YamlParameterSource::fromFile("/nonexistent/params.yaml"), std::runtime_error);
  EXPECT_THROW(YamlParameterSource::fromString("- 1\n- 2\n"), std::runtime_error);
  EXPECT_THROW(YamlParameterSource::fromString("DJNN: 3\n", "DJNN"), std::runtime_error);
  EXPECT_THROW(YamlParameterSource::fromString("a: [1\n"), std::runtime_error);
  double d = 0;
  EXPECT_FALSE(YamlParameterSource::fromString("").get("a", &d));
}

}  // namespace test_plugins
}  // namespace ekf_slam
