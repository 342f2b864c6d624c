// The replay tool and its library function on the example problems of test/data. Expected
// pairings were derived by hand from the problems' geometry (the comments say why) and the joint
// Mahalanobis distances independently in numpy (numeric Jacobians, full H P H^T + R).
#include <fstream>

#include <gtest/gtest.h>

#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "associators.h"
#include "ekf_slam/app/association_problem.h"
#include "ekf_slam/app/yaml_parameter_source.h"

namespace ekf_slam {
namespace test_replay_association {

const std::string kData = EKF_SLAM_TEST_DATA;

/// As the tool does it: problem alphas, overridden by the parameter file.
ReplayResult replay(const AssociationProblem& problem, const std::string& name,
                    const std::string& yaml = "") {
  auto params = YamlParameterSource::fromString(yaml, name);
  for (const auto& [k, v] : problemParameters(problem, name)) {
    if (!params.contains(k)) params.set(k, v);
  }
  auto assoc = makeAssociator(name);
  assoc->configure(params);
  return replayAssociation(problem, *assoc);
}

struct Case {
  std::string problem;
  std::string associator;
  std::vector<int> landmark;
  double joint_mahalanobis;  // < 0: not checked
};

// shifted_row: the vehicle is 1.2 m left of its estimate; observation i sees landmark i, and is
// individually compatible with landmarks i (M ~ 1.4) and i - 1 (M ~ 0.65).
//  - NN takes the least M + ln|S| for each observation alone: i - 1, so observations 0 and 1 both
//    take landmark 0 (a jointly absurd hypothesis, D^2 ~ 667).
//  - JCBB maximises the number of jointly compatible pairings: only the true hypothesis has 5.
//  - NNJCBB: NN interferes, so JCBB runs.
//  - Hungarian: the true assignment costs 5 x ~1.45 = 7.3; the shifted one 4 x 0.65 + the gate
//    5.99 for the unpaired observation 0 = 8.6.
//  - DJNN: no landmark was paired before, so the scan is a loop closure and the joint decision
//    takes the joint ML hypothesis, the true one. The paper's DJNN (kPaperDjnn), case 2
//    (seed 000 eq. 6): v_bar from the unique pairs (2-4, shifted by one) moves observation 1
//    onto landmark 0, which it wins; observation 0 is left without a landmark.
// sensor_offset_wrap: sensor mounted sideways facing backwards; landmarks 1 and 2 lie behind the
//   sensor at bearings near +-pi and observation 3's bearing wraps. The paper's field of view
//   (pi, seed 000 eq. 10) excludes them; params_360.yaml widens it. DJNN's joint decision at a
//   loop closure adds the landmarks that gate with an observation to the candidates.
// clear: obvious pairs, observation 1 is clutter.
const std::vector<Case> kCases = {
    {"clear", "NN", {1, -1, 2, 0}, 0.30740741213879696},
    {"clear", "JCBB", {1, -1, 2, 0}, 0.30740741213879696},
    {"clear", "DJNN", {1, -1, 2, 0}, 0.30740741213879696},
    {"clear", "NNJCBB", {1, -1, 2, 0}, 0.30740741213879696},
    {"clear", "Hungarian", {1, -1, 2, 0}, 0.30740741213879696},
    {"shifted_row", "NN", {0, 0, 1, 2, 3}, -1.0},
    {"shifted_row", "JCBB", {0, 1, 2, 3, 4}, 1.6259514398184607},
    {"shifted_row", "NNJCBB", {0, 1, 2, 3, 4}, 1.6259514398184607},
    {"shifted_row", "Hungarian", {0, 1, 2, 3, 4}, 1.6259514398184607},
    {"shifted_row", "DJNN", {0, 1, 2, 3, 4}, 1.6259514398184607},
    {"sensor_offset_wrap", "NN", {2, 0, -1, 1}, 0.46440925372528186},
    {"sensor_offset_wrap", "JCBB", {2, 0, -1, 1}, 0.46440925372528186},
    {"sensor_offset_wrap", "NNJCBB", {2, 0, -1, 1}, 0.46440925372528186},
    {"sensor_offset_wrap", "Hungarian", {2, 0, -1, 1}, 0.46440925372528186},
    {"sensor_offset_wrap", "DJNN", {2, 0, -1, 1}, 0.46440925372528186},
};

// DJNN without the joint decision at loop closures, as seed 000 publishes it (the problem gives
// the gates).
const std::string kPaperDjnn = "loop_closure_age: 0\nestimate_landmark_density: false\n";

TEST(ReplayAssociation, ExpectedPairsPerAssociator) {
  for (const auto& c : kCases) {
    SCOPED_TRACE(c.problem + " " + c.associator);
    const auto problem = readAssociationProblem(kData + "/" + c.problem + ".json");
    const auto r = replay(problem, c.associator);
    EXPECT_EQ(r.landmark, c.landmark);
    if (c.joint_mahalanobis >= 0.0) {
      EXPECT_NEAR(r.joint_mahalanobis, c.joint_mahalanobis, 1e-6 * c.joint_mahalanobis);
    }
    ASSERT_EQ(r.result.decision.size(), c.landmark.size());
    for (std::size_t i = 0; i < c.landmark.size(); ++i) {
      EXPECT_EQ(r.result.decision[i] == Decision::kPaired, c.landmark[i] >= 0) << "obs " << i;
    }
  }
}

TEST(ReplayAssociation, ThePapersDjnnKeepsTheShiftAndItsFieldOfView) {
  const auto shifted =
      replay(readAssociationProblem(kData + "/shifted_row.json"), "DJNN", kPaperDjnn);
  EXPECT_EQ(shifted.landmark, (std::vector<int>{-1, 0, 1, 2, 3}));
  EXPECT_NEAR(shifted.joint_mahalanobis, 0.6669332146367519, 1e-6);
  const auto behind =
      replay(readAssociationProblem(kData + "/sensor_offset_wrap.json"), "DJNN", kPaperDjnn);
  EXPECT_EQ(behind.landmark, (std::vector<int>{-1, 0, -1, -1}));
}

TEST(ReplayAssociation, DjnnSeesBehindWithA360DegreeFieldOfView) {
  const auto problem = readAssociationProblem(kData + "/sensor_offset_wrap.json");
  const auto yaml = YamlParameterSource::fromFile(kData + "/params_360.yaml", "DJNN");
  DJNN djnn;
  djnn.configure(yaml);
  const auto r = replayAssociation(problem, djnn);
  EXPECT_EQ(r.landmark, (std::vector<int>{2, 0, -1, 1}));
  EXPECT_NEAR(r.joint_mahalanobis, 0.46440925372528186, 1e-6);
}

TEST(ReplayAssociation, ProblemAlphaReachesTheAssociator) {
  // alpha = 0.5: gate chi2(2, 0.5) = 1.386 keeps only the shifted pairs (M ~ 0.65): JCBB can
  // no longer see the true hypothesis.
  auto problem = readAssociationProblem(kData + "/shifted_row.json");
  problem.chi2_alpha_individual = 0.5;
  EXPECT_EQ(replay(problem, "JCBB").landmark, (std::vector<int>{-1, 0, 1, 2, 3}));
  // ... unless the parameter file sets the gate itself.
  EXPECT_EQ(replay(problem, "JCBB", "individual_probability: 0.95\n").landmark,
            (std::vector<int>{0, 1, 2, 3, 4}));

  const auto params = problemParameters(problem, "ekf_slam/JCBB");
  const std::map<std::string, std::string> m(params.begin(), params.end());
  ASSERT_EQ(m.size(), 2u);
  EXPECT_DOUBLE_EQ(std::stod(m.at("individual_probability")), 0.5);
  EXPECT_DOUBLE_EQ(std::stod(m.at("joint_probability")), 0.95);
  const auto djnn = problemParameters(problem, "DJNN");
  ASSERT_EQ(djnn.size(), 2u);
  EXPECT_EQ(djnn[0].first, "individual_probability");
  EXPECT_EQ(djnn[1].first, "ambiguity_probability");
  EXPECT_DOUBLE_EQ(std::stod(djnn[0].second), 0.5);
}

// --- the JSON format ------------------------------------------------------------------------

TEST(AssociationProblem, RoundTripsThroughJson) {
  auto p = readAssociationProblem(kData + "/sensor_offset_wrap.json");
  p.chi2_alpha_joint = 0.01;
  const auto q = parseAssociationProblem(toJson(p), "round trip");
  EXPECT_EQ(q.state, p.state);
  EXPECT_EQ(q.covariance, p.covariance);
  EXPECT_EQ(q.sensor_offset, p.sensor_offset);
  EXPECT_EQ(q.R, p.R);
  ASSERT_EQ(q.observations.size(), p.observations.size());
  for (std::size_t i = 0; i < p.observations.size(); ++i) {
    EXPECT_EQ(q.observations[i], p.observations[i]);
  }
  EXPECT_FALSE(q.chi2_alpha_individual.has_value());
  EXPECT_EQ(q.chi2_alpha_joint, 0.01);
  EXPECT_EQ(q.description, p.description);

  const std::string path = ::testing::TempDir() + "/problem.json";
  writeAssociationProblem(p, path);
  EXPECT_EQ(readAssociationProblem(path).covariance, p.covariance);
}

TEST(AssociationProblem, FromEkfKeepsStateOrder) {
  EkfSlam ekf;
  ekf.reset(Eigen::Vector3d(1.0, 2.0, 0.3), Eigen::Matrix3d::Identity() * 0.01);
  const RangeBearingModel model(Eigen::Vector3d(0.5, 0.0, 0.0));
  Observation o;
  o.z << 5.0, 0.2;
  o.R = Eigen::Vector2d(0.04, 0.001).asDiagonal();
  ekf.addLandmark(o.z, o.R, model);
  ekf.insertLandmark(Eigen::Vector2d(-3.0, 4.0), Eigen::Matrix2d::Identity());
  const auto p = makeAssociationProblem(ekf, model, {o, o});
  EXPECT_EQ(p.state, ekf.mean());
  EXPECT_EQ(p.covariance, ekf.covariance());
  EXPECT_EQ(p.numLandmarks(), 2u);
  EXPECT_EQ(p.sensor_offset, model.sensorOffset());
  EXPECT_EQ(p.R, o.R);
  Observation other = o;
  other.R *= 2.0;
  EXPECT_THROW(makeAssociationProblem(ekf, model, {o, other}), std::invalid_argument);
}

void expectRejected(const std::string& json, const std::string& part) {
  try {
    parseAssociationProblem(json, "t.json");
    ADD_FAILURE() << "accepted: " << json;
  } catch (const ProblemError& e) {
    EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("t.json"), std::string::npos) << e.what();
  }
}

TEST(AssociationProblem, RejectsMalformedProblems) {
  const std::string cov3 = R"("covariance": [[1,0,0],[0,1,0],[0,0,1]])";
  const std::string ok = R"({"state": [0,0,0], )" + cov3 + R"(, "observations": [[1, 0]])";
  EXPECT_NO_THROW(parseAssociationProblem(ok + "}"));
  // Flat row-major covariance and R are accepted too.
  const auto flat = parseAssociationProblem(
      R"({"state": [0,0,0], "covariance": [1,0,0, 0,2,0, 0,0,3], "R": [1, 0, 0, 2],
          "observations": []})");
  EXPECT_DOUBLE_EQ(flat.covariance(1, 1), 2.0);
  EXPECT_DOUBLE_EQ(flat.R(1, 1), 2.0);

  expectRejected("{", "not valid JSON");
  expectRejected(R"({"state": [0,0,0], "observations": []})", "covariance");
  expectRejected(R"({"state": [0,0,0,1], )" + cov3 + R"(, "observations": []})", "state");
  expectRejected(R"({"state": [0,0,0,1,1], )" + cov3 + R"(, "observations": []})", "covariance");
  expectRejected(ok + R"(, "chi2_alpha_individual": 0.95})", "chi2_alpha_individual");
  expectRejected(ok + R"(, "chi2_alpha_joint": 0})", "chi2_alpha_joint");
  expectRejected(ok + R"(, "chi2_alpha_indvidual": 0.05})", "unknown field 'chi2_alpha_indvidual'");
  expectRejected(ok + R"(, "R": [[1, 0.5], [0, 1]]})", "R");
  expectRejected(ok + R"(, "sensor_offset": [1, 2]})", "sensor_offset");
  expectRejected(R"({"state": [0,0,0], "covariance": [[1,0,0],[0,1,0],[0.5,0,1]],
                     "observations": []})",
                 "symmetric");
  expectRejected(R"({"state": [0,0,0], )" + cov3 + R"(, "observations": [[1, 0, 2]]})",
                 "observations[0]");
  expectRejected(R"({"state": [0,0,"a"], )" + cov3 + R"(, "observations": []})", "state[2]");
  // Symmetric, non-negative diagonal, but indefinite (eigenvalues 3 and -1).
  expectRejected(R"({"state": [0,0,0], "covariance": [[1,2,0],[2,1,0],[0,0,1]],
                     "observations": []})",
                 "positive semi-definite");
  expectRejected(R"({"state": [0,0,1e400], )" + cov3 + R"(, "observations": []})",
                 "not valid JSON");
  EXPECT_NO_THROW(parseAssociationProblem(ok + R"(, "_note": "annotations are free"})"));
  EXPECT_THROW(readAssociationProblem(kData + "/does_not_exist.json"), ProblemError);
}

// --- the command ----------------------------------------------------------------------------

/// Runs the tool; returns its exit code and its stdout (stderr too when `with_stderr`).
int run(const std::string& args, std::string* out, bool with_stderr = false) {
  const std::string cmd =
      std::string(REPLAY_ASSOCIATION_BIN) + " " + args + (with_stderr ? " 2>&1" : " 2>/dev/null");
  FILE* pipe = popen(cmd.c_str(), "r");
  if (pipe == nullptr) return -1;
  char buf[512];
  out->clear();
  while (fgets(buf, sizeof buf, pipe) != nullptr) *out += buf;
  const int status = pclose(pipe);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(ReplayAssociationCommand, PrintsPairsAndJointDistance) {
  std::string out;
  ASSERT_EQ(run("--problem " + kData + "/shifted_row.json --associator ekf_slam/JCBB", &out), 0);
  EXPECT_EQ(out, "0 0\n1 1\n2 2\n3 3\n4 4\njoint_mahalanobis 1.62595144\n");
  ASSERT_EQ(run("--problem " + kData + "/shifted_row.json --associator NN", &out), 0);
  EXPECT_EQ(out.substr(0, 20), "0 0\n1 0\n2 1\n3 2\n4 3\n");
  ASSERT_EQ(run("--problem " + kData +
                    "/sensor_offset_wrap.json --associator ekf_slam/DJNN "
                    "--params " +
                    kData + "/params_360.yaml",
                &out),
            0);
  EXPECT_EQ(out, "0 2\n1 0\n2 -1\n3 1\njoint_mahalanobis 0.464409248\n");
}

TEST(ReplayAssociationCommand, FailsClearly) {
  std::string out;
  EXPECT_EQ(run("--problem " + kData + "/clear.json --associator ekf_slam/DJN", &out, true), 1);
  EXPECT_NE(out.find("unknown associator 'ekf_slam/DJN'"), std::string::npos) << out;
  EXPECT_NE(out.find("ekf_slam/DJNN, ekf_slam/Hungarian, ekf_slam/JCBB, ekf_slam/NN, "
                     "ekf_slam/NNJCBB"),
            std::string::npos)
      << out;
  EXPECT_EQ(run("--problem /nonexistent.json --associator DJNN", &out, true), 1);
  EXPECT_NE(out.find("/nonexistent.json: cannot open"), std::string::npos) << out;
  // A number beyond double: the error names the file.
  const std::string overflow = testing::TempDir() + "/overflow.json";
  std::ofstream(overflow) << R"({"state": [0,0,1e999], "covariance": [1,0,0,0,1,0,0,0,1],
                                 "observations": []})";
  EXPECT_EQ(run("--problem " + overflow + " --associator NN", &out, true), 1);
  EXPECT_NE(out.find(overflow + ": not valid JSON"), std::string::npos) << out;
  // A degenerate R: NN pairs two observations with one landmark, their joint covariance is
  // singular, the distance infinite: an error, never rc 0 with "inf".
  AssociationProblem p = readAssociationProblem(kData + "/shifted_row.json");
  p.R << 0.01, 0.0, 0.0, 1e-308;
  const std::string degenerate = testing::TempDir() + "/degenerate.json";
  writeAssociationProblem(p, degenerate);
  EXPECT_EQ(run("--problem " + degenerate + " --associator NN", &out, true), 1);
  EXPECT_EQ(out.find("joint_mahalanobis inf"), std::string::npos) << out;
  EXPECT_NE(out.find(degenerate + ": the joint Mahalanobis distance"), std::string::npos) << out;
  EXPECT_EQ(run("--problem " + kData + "/clear.json", &out, true), 2);
  EXPECT_NE(out.find("usage"), std::string::npos) << out;
}

}  // namespace test_replay_association
}  // namespace ekf_slam
