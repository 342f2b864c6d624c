// MapParameterSource conversions and ParameterReader defaults / validation, and that every
// associator of this part reports a bad parameter by name.
#include <gtest/gtest.h>

#include <map>
#include <string>
#include <vector>

#include "ekf_slam/core/association/hungarian.h"
#include "ekf_slam/core/association/jcbb.h"
#include "ekf_slam/core/association/nn.h"
#include "ekf_slam/core/association/nnjcbb.h"
#include "ekf_slam/core/common/parameters.h"
#include "ekf_slam/core/common/recording_parameter_source.h"

namespace ekf_slam {
namespace test_parameters {

// Expects `f` to throw a ParameterError whose message names `name`.
template <typename F>
void expectNamedError(F f, const std::string& name) {
  try {
    f();
    ADD_FAILURE() << "no ParameterError for " << name;
  } catch (const ParameterError& e) {
    EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
  }
}

TEST(MapParameterSource, Conversions) {
  MapParameterSource s({{"d", " 2.5 "},
                        {"i", "-7"},
                        {"b1", "true"},
                        {"b2", "No"},
                        {"s", "hello"},
                        {"bad", "2.5x"},
                        {"f", "1.5"}});
  double d = 0;
  int i = 0;
  bool b = false;
  std::string str;
  EXPECT_TRUE(s.get("d", &d));
  EXPECT_DOUBLE_EQ(d, 2.5);
  EXPECT_TRUE(s.get("i", &i));
  EXPECT_EQ(i, -7);
  EXPECT_TRUE(s.get("i", &d));  // an integer is a valid number
  EXPECT_DOUBLE_EQ(d, -7.0);
  EXPECT_TRUE(s.get("b1", &b));
  EXPECT_TRUE(b);
  EXPECT_TRUE(s.get("b2", &b));
  EXPECT_FALSE(b);
  EXPECT_TRUE(s.get("s", &str));
  EXPECT_EQ(str, "hello");
  EXPECT_FALSE(s.get("missing", &d));
  EXPECT_DOUBLE_EQ(d, -7.0);  // untouched
  EXPECT_THROW(s.get("bad", &d), std::invalid_argument);
  EXPECT_THROW(s.get("f", &i), std::invalid_argument);  // not an integer
  EXPECT_THROW(s.get("s", &b), std::invalid_argument);
}

TEST(ParameterReader, DefaultsAndValues) {
  MapParameterSource s({{"gate", "7.5"}, {"n", "12"}, {"flag", "1"}, {"mode", "b"}});
  ParameterReader r(s);
  EXPECT_DOUBLE_EQ(r.positive("gate", 1.0), 7.5);
  EXPECT_DOUBLE_EQ(r.positive("absent", 3.0), 3.0);
  EXPECT_DOUBLE_EQ(r.probability("p", 0.95), 0.95);
  EXPECT_EQ(r.integer("n", 3, 0, 100), 12);
  EXPECT_EQ(r.integer("m", 3, 0, 100), 3);
  EXPECT_TRUE(r.flag("flag", false));
  EXPECT_FALSE(r.flag("other", false));
  EXPECT_EQ(r.text("mode", "a", {"a", "b"}), "b");
  EXPECT_EQ(r.text("mode2", "a", {"a", "b"}), "a");
  EXPECT_DOUBLE_EQ(r.inRange("gate", 0.0, 7.5, 7.5), 7.5);
}

TEST(ParameterReader, BadValuesNameTheParameter) {
  MapParameterSource s({{"neg", "-1"},
                        {"zero", "0"},
                        {"p", "1.0"},
                        {"n", "101"},
                        {"nan", "nan"},
                        {"word", "abc"},
                        {"mode", "c"},
                        {"flag", "maybe"}},
                       "/ekf_slam/X/");
  ParameterReader r(s);
  expectNamedError([&] { r.positive("neg", 1.0); }, "/ekf_slam/X/neg");
  expectNamedError([&] { r.positive("zero", 1.0); }, "/ekf_slam/X/zero");
  expectNamedError([&] { r.nonNegative("neg", 1.0); }, "/ekf_slam/X/neg");
  expectNamedError([&] { r.probability("p", 0.5); }, "/ekf_slam/X/p");
  expectNamedError([&] { r.integer("n", 1, 0, 100); }, "/ekf_slam/X/n");
  expectNamedError([&] { r.number("nan", 1.0); }, "/ekf_slam/X/nan");
  expectNamedError([&] { r.number("word", 1.0); }, "/ekf_slam/X/word");
  expectNamedError([&] { r.integer("word", 1, 0, 5); }, "/ekf_slam/X/word");
  expectNamedError([&] { r.text("mode", "a", {"a", "b"}); }, "/ekf_slam/X/mode");
  expectNamedError([&] { r.flag("flag", true); }, "/ekf_slam/X/flag");
  expectNamedError([&] { r.inRange("neg", 0.0, 0.0, 1.0); }, "/ekf_slam/X/neg");
  expectNamedError([&] { r.fail("anything", "custom"); }, "/ekf_slam/X/anything");
}

TEST(RecordingParameterSource, NamesWhatNobodyRead) {
  MapParameterSource inner;
  inner.set("sigma_range", "0.5");
  inner.set("sigma_rnage", "0.4");
  inner.set("mode", "slam");
  const RecordingParameterSource source(inner, {"mode", "sigma_range", "sigma_rnage"});
  const ParameterReader r(source);
  EXPECT_EQ(r.positive("sigma_range", 1.0), 0.5);
  EXPECT_EQ(r.text("mode", "slam"), "slam");
  EXPECT_EQ(r.flag("publish_tf", true), true);  // read but not set: fine
  EXPECT_EQ(source.unread(), std::vector<std::string>({"sigma_rnage"}));
  EXPECT_TRUE(source.unread({"sigma_rnage"}).empty());
  try {
    source.rejectUnread();
    FAIL() << "expected ParameterError";
  } catch (const ParameterError& e) {
    EXPECT_NE(
        std::string(e.what()).find("unknown parameter sigma_rnage (did you mean sigma_range?)"),
        std::string::npos)
        << e.what();
  }
}

TEST(RecordingParameterSource, NearestNameIsOnlyACloseOne) {
  EXPECT_EQ(nearestName("sensor_rnage", {"sensor_range", "range_margin"}), "sensor_range");
  EXPECT_EQ(nearestName("queue", {"sensor_range", "range_margin"}), "");
  EXPECT_EQ(nearestName("x", {}), "");
}

TEST(AssociatorParameters, DefaultsApplied) {
  MapParameterSource empty;
  NN nn;
  nn.configure(empty);
  EXPECT_DOUBLE_EQ(nn.gating().individual_probability, 0.95);
  EXPECT_NEAR(nn.gating().individual_gate, 5.9915, 1e-4);
  EXPECT_DOUBLE_EQ(nn.gating().candidate_margin, 5.0);
  EXPECT_NEAR(nn.gating().new_landmark_gate, 18.4207, 1e-4);
  EXPECT_FALSE(nn.mutualExclusion());

  JCBB jcbb;
  jcbb.configure(empty);
  EXPECT_DOUBLE_EQ(jcbb.options().joint_probability, 0.95);
  EXPECT_EQ(jcbb.options().max_nodes, 100000);
  EXPECT_FALSE(jcbb.options().prefer_least_distance);

  NNJCBB hybrid;
  hybrid.configure(empty);
  EXPECT_TRUE(hybrid.options().prefer_least_distance);
  EXPECT_DOUBLE_EQ(hybrid.interferenceThreshold(), 0.0);
  EXPECT_EQ(hybrid.jcbbEveryNScans(), 0);

  Hungarian h;
  h.configure(empty);
  EXPECT_NEAR(h.gating().individual_gate, 5.9915, 1e-4);
}

TEST(AssociatorParameters, ValuesRead) {
  MapParameterSource s({{"individual_probability", "0.99"},
                        {"max_nodes", "50"},
                        {"prefer_least_distance", "true"},
                        {"candidate_margin", "2"},
                        {"new_landmark_probability", "0.999"}});
  JCBB jcbb;
  jcbb.configure(s);
  EXPECT_NEAR(jcbb.gating().individual_gate, 9.2103, 1e-4);
  EXPECT_NEAR(jcbb.gating().new_landmark_gate, 13.8155, 1e-4);
  EXPECT_DOUBLE_EQ(jcbb.gating().candidate_margin, 2.0);
  EXPECT_EQ(jcbb.options().max_nodes, 50);
  EXPECT_TRUE(jcbb.options().prefer_least_distance);
}

TEST(AssociatorParameters, BadValuesNamed) {
  auto configureWith = [](DataAssociation* a, const std::string& name, const std::string& value) {
    MapParameterSource s(std::map<std::string, std::string>{{name, value}});
    a->configure(s);
  };
  NN nn;
  JCBB jcbb;
  NNJCBB hybrid;
  Hungarian h;
  for (DataAssociation* a : std::initializer_list<DataAssociation*>{&nn, &jcbb, &hybrid, &h}) {
    expectNamedError([&] { configureWith(a, "individual_probability", "1.5"); },
                     "individual_probability");
    expectNamedError([&] { configureWith(a, "candidate_margin", "-1"); }, "candidate_margin");
    // Inside the pairing gate: would create duplicates.
    expectNamedError([&] { configureWith(a, "new_landmark_probability", "0.5"); },
                     "new_landmark_probability");
  }
  expectNamedError([&] { configureWith(&nn, "mutual_exclusion", "perhaps"); }, "mutual_exclusion");
  expectNamedError([&] { configureWith(&jcbb, "max_nodes", "0"); }, "max_nodes");
  expectNamedError([&] { configureWith(&jcbb, "joint_probability", "0"); }, "joint_probability");
  expectNamedError([&] { configureWith(&hybrid, "interference_threshold", "2"); },
                   "interference_threshold");
  expectNamedError([&] { configureWith(&hybrid, "jcbb_every_n_scans", "-3"); },
                   "jcbb_every_n_scans");
}

}  // namespace test_parameters
}  // namespace ekf_slam
