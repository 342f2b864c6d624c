#include "ekf_slam/app/association_problem.h"

#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <nlohmann/json.hpp>

#include "ekf_slam/core/filter/landmark_index.h"

namespace ekf_slam {

namespace {

using Json = nlohmann::json;

[[noreturn]] void fail(const std::string& origin, const std::string& what) {
  throw ProblemError(origin + ": " + what);
}

// Larger magnitudes overflow the arithmetic of an association (squares of squares).
constexpr double kMaxMagnitude = 1e100;

double number(const Json& j, const std::string& origin, const std::string& field) {
  if (!j.is_number()) fail(origin, field + " must be a number");
  const double v = j.get<double>();
  if (!std::isfinite(v)) fail(origin, field + " must be finite");
  if (std::abs(v) > kMaxMagnitude) fail(origin, field + " must lie within +-1e100");
  return v;
}

std::vector<double> numbers(const Json& j, const std::string& origin, const std::string& field) {
  if (!j.is_array()) fail(origin, field + " must be a list of numbers");
  std::vector<double> out;
  out.reserve(j.size());
  for (std::size_t i = 0; i < j.size(); ++i) {
    out.push_back(number(j[i], origin, field + "[" + std::to_string(i) + "]"));
  }
  return out;
}

// A square matrix given either flat (row-major) or as a list of rows.
Eigen::MatrixXd squareMatrix(const Json& j, long n, const std::string& origin,
                             const std::string& field) {
  if (!j.is_array()) fail(origin, field + " must be a list");
  Eigen::MatrixXd m(n, n);
  if (!j.empty() && j[0].is_array()) {
    if (static_cast<long>(j.size()) != n) {
      fail(origin,
           field + " must have " + std::to_string(n) + " rows, has " + std::to_string(j.size()));
    }
    for (long r = 0; r < n; ++r) {
      const auto row = numbers(j[r], origin, field + "[" + std::to_string(r) + "]");
      if (static_cast<long>(row.size()) != n) {
        fail(origin, field + "[" + std::to_string(r) + "] must have " + std::to_string(n) +
                         " entries, has " + std::to_string(row.size()));
      }
      for (long c = 0; c < n; ++c) m(r, c) = row[c];
    }
  } else {
    const auto flat = numbers(j, origin, field);
    if (static_cast<long>(flat.size()) != n * n) {
      fail(origin, field + " must have " + std::to_string(n * n) + " entries (" +
                       std::to_string(n) + " x " + std::to_string(n) + " row-major), has " +
                       std::to_string(flat.size()));
    }
    for (long r = 0; r < n; ++r)
      for (long c = 0; c < n; ++c) m(r, c) = flat[r * n + c];
  }
  return m;
}

double alpha(const Json& j, const std::string& origin, const std::string& field) {
  const double a = number(j, origin, field);
  if (!(a > 0.0 && a <= 0.5)) {
    fail(origin, field + " = " + std::to_string(a) +
                     ": alpha is the tail probability of the gate chi2(d, 1 - alpha), "
                     "0 < alpha <= 0.5 (e.g. 0.05, not 0.95)");
  }
  return a;
}

Json rows(const Eigen::MatrixXd& m) {
  Json out = Json::array();
  for (long r = 0; r < m.rows(); ++r) {
    Json row = Json::array();
    for (long c = 0; c < m.cols(); ++c) row.push_back(m(r, c));
    out.push_back(std::move(row));
  }
  return out;
}

std::string shortName(const std::string& name) {
  const auto slash = name.rfind('/');
  return slash == std::string::npos ? name : name.substr(slash + 1);
}

std::string probabilityText(double alpha) {
  std::ostringstream s;
  s.precision(17);
  s << 1.0 - alpha;
  return s.str();
}

}  // namespace

void AssociationProblem::validate(const std::string& origin) const {
  if (state.size() < 3 || (state.size() - 3) % 2 != 0) {
    fail(origin, "state must hold x, y, yaw and then x, y per landmark (3 + 2n numbers), has " +
                     std::to_string(state.size()));
  }
  if (!state.allFinite()) fail(origin, "state must be finite");
  const long n = state.size();
  if (covariance.rows() != n || covariance.cols() != n) {
    fail(origin, "covariance must be " + std::to_string(n) + " x " + std::to_string(n));
  }
  if (!covariance.allFinite()) fail(origin, "covariance must be finite");
  // Entry by entry: a tolerance relative to the largest entry would let a huge variance hide
  // any asymmetry elsewhere.
  const Eigen::ArrayXXd a = covariance.array();
  const Eigen::ArrayXXd tolerance = 1e-9 * a.abs().max(a.transpose().abs()).max(1.0);
  if (((a - a.transpose()).abs() > tolerance).any()) {
    fail(origin, "covariance must be symmetric");
  }
  if ((covariance.diagonal().array() < 0.0).any()) {
    fail(origin, "covariance must have a non-negative diagonal");
  }
  // An indefinite covariance makes innovation covariances indefinite: every associator would
  // then gate on negative distances and they disagree wildly (issue 15). Rounding is allowed.
  const Eigen::VectorXd eig =
      Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(covariance, Eigen::EigenvaluesOnly)
          .eigenvalues();
  if (eig.minCoeff() < -1e-9 * std::max(1.0, eig.cwiseAbs().maxCoeff())) {
    fail(origin, "covariance must be positive semi-definite (smallest eigenvalue " +
                     std::to_string(eig.minCoeff()) + ")");
  }
  if (!sensor_offset.allFinite()) fail(origin, "sensor_offset must be finite");
  if (!R.allFinite() || std::abs(R(0, 1) - R(1, 0)) > 1e-12 * R.cwiseAbs().maxCoeff() ||
      R(0, 0) <= 0.0 || R.determinant() <= 0.0) {
    fail(origin, "R must be a symmetric positive definite 2 x 2 matrix");
  }
  for (std::size_t i = 0; i < observations.size(); ++i) {
    if (!observations[i].allFinite() || observations[i].x() < 0.0) {
      fail(origin, "observations[" + std::to_string(i) +
                       "] must be [range, bearing] with a finite range >= 0");
    }
  }
  for (const auto& [field, value] : {std::make_pair("chi2_alpha_individual", chi2_alpha_individual),
                                     std::make_pair("chi2_alpha_joint", chi2_alpha_joint)}) {
    if (value && !(*value > 0.0 && *value <= 0.5)) {
      fail(origin, std::string(field) + " must satisfy 0 < alpha <= 0.5");
    }
  }
}

AssociationProblem parseAssociationProblem(const std::string& json_text,
                                           const std::string& origin) {
  Json j;
  try {
    j = Json::parse(json_text);
  } catch (const Json::exception& e) {  // syntax, or a number out of range (1e400)
    fail(origin, std::string("not valid JSON: ") + e.what());
  }
  if (!j.is_object()) fail(origin, "expected a JSON object");

  // Unknown keys are errors, so that a misspelt optional field is not silently ignored; keys
  // starting with '_' are free annotations.
  static const std::set<std::string> kKeys = {"state",
                                              "covariance",
                                              "sensor_offset",
                                              "R",
                                              "observations",
                                              "chi2_alpha_individual",
                                              "chi2_alpha_joint",
                                              "description"};
  for (const auto& item : j.items()) {
    if (kKeys.count(item.key()) == 0 && item.key().rfind('_', 0) != 0) {
      fail(origin, "unknown field '" + item.key() +
                       "' (known: state, covariance, sensor_offset, R, observations, "
                       "chi2_alpha_individual, chi2_alpha_joint, description, _*)");
    }
  }
  for (const char* key : {"state", "covariance", "observations"}) {
    if (!j.contains(key)) fail(origin, std::string("missing field '") + key + "'");
  }

  AssociationProblem p;
  const auto state = numbers(j["state"], origin, "state");
  p.state = Eigen::Map<const Eigen::VectorXd>(state.data(), static_cast<long>(state.size()));
  if (state.size() < 3 || (state.size() - 3) % 2 != 0) {
    fail(origin, "state must hold x, y, yaw and then x, y per landmark (3 + 2n numbers), has " +
                     std::to_string(state.size()));
  }
  p.covariance = squareMatrix(j["covariance"], p.state.size(), origin, "covariance");
  if (j.contains("sensor_offset")) {
    const auto o = numbers(j["sensor_offset"], origin, "sensor_offset");
    if (o.size() != 3) fail(origin, "sensor_offset must be [x, y, yaw]");
    p.sensor_offset << o[0], o[1], o[2];
  }
  if (j.contains("R")) p.R = squareMatrix(j["R"], 2, origin, "R");
  const Json& obs = j["observations"];
  if (!obs.is_array()) fail(origin, "observations must be a list of [range, bearing]");
  for (std::size_t i = 0; i < obs.size(); ++i) {
    const auto z = numbers(obs[i], origin, "observations[" + std::to_string(i) + "]");
    if (z.size() != 2) {
      fail(origin, "observations[" + std::to_string(i) + "] must be [range, bearing]");
    }
    p.observations.emplace_back(z[0], z[1]);
  }
  if (j.contains("chi2_alpha_individual")) {
    p.chi2_alpha_individual = alpha(j["chi2_alpha_individual"], origin, "chi2_alpha_individual");
  }
  if (j.contains("chi2_alpha_joint")) {
    p.chi2_alpha_joint = alpha(j["chi2_alpha_joint"], origin, "chi2_alpha_joint");
  }
  if (j.contains("description")) {
    if (!j["description"].is_string()) fail(origin, "description must be a string");
    p.description = j["description"].get<std::string>();
  }
  p.validate(origin);
  return p;
}

AssociationProblem readAssociationProblem(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ProblemError(path + ": cannot open");
  std::stringstream text;
  text << in.rdbuf();
  return parseAssociationProblem(text.str(), path);
}

std::string toJson(const AssociationProblem& p) {
  Json j;
  if (!p.description.empty()) j["description"] = p.description;
  j["state"] = std::vector<double>(p.state.data(), p.state.data() + p.state.size());
  j["covariance"] = rows(p.covariance);
  j["sensor_offset"] = {p.sensor_offset.x(), p.sensor_offset.y(), p.sensor_offset.z()};
  j["R"] = rows(p.R);
  Json obs = Json::array();
  for (const auto& z : p.observations) obs.push_back({z.x(), z.y()});
  j["observations"] = std::move(obs);
  if (p.chi2_alpha_individual) j["chi2_alpha_individual"] = *p.chi2_alpha_individual;
  if (p.chi2_alpha_joint) j["chi2_alpha_joint"] = *p.chi2_alpha_joint;
  return j.dump(1) + "\n";
}

void writeAssociationProblem(const AssociationProblem& problem, const std::string& path) {
  std::ofstream out(path);
  if (!out) throw ProblemError(path + ": cannot open for writing");
  out << toJson(problem);
  if (!out) throw ProblemError(path + ": write failed");
}

AssociationProblem makeAssociationProblem(const EkfSlam& ekf, const RangeBearingModel& model,
                                          const std::vector<Observation>& observations) {
  AssociationProblem p;
  // The file holds pose and landmarks only (3 + 2n): odometry correction states (rows 3..3+k)
  // and pose clones (after the map) play no part in association, so they are marginalised out
  // (dropped).
  const Eigen::Index k = ekf.correctionDim();
  const Eigen::Index n = 2 * static_cast<Eigen::Index>(ekf.numLandmarks());
  p.state.resize(3 + n);
  p.state << ekf.mean().head(3), ekf.mean().segment(3 + k, n);
  p.covariance.resize(3 + n, 3 + n);
  const auto P = ekf.covariance();  // a view, no copy
  p.covariance << P.topLeftCorner(3, 3), P.block(0, 3 + k, 3, n), P.block(3 + k, 0, n, 3),
      P.block(3 + k, 3 + k, n, n);
  p.sensor_offset = model.sensorOffset();
  if (!observations.empty()) p.R = observations.front().R;
  for (const auto& o : observations) {
    if (o.R != p.R) {
      throw std::invalid_argument("makeAssociationProblem: observations with different R");
    }
    p.observations.push_back(o.z);
  }
  return p;
}

std::vector<std::pair<std::string, std::string>> problemParameters(
    const AssociationProblem& problem, const std::string& name) {
  // Every associator names its individual gate individual_probability (1 - alpha); JCBB and
  // NNJCBB also have a joint gate (1 - alpha_joint).
  const std::string algo = shortName(name);
  std::vector<std::pair<std::string, std::string>> out;
  if (problem.chi2_alpha_individual) {
    const std::string p = probabilityText(*problem.chi2_alpha_individual);
    out.emplace_back("individual_probability", p);
    // DJNN's ambiguity gate must not be narrower than its pairing gate.
    if (algo == "DJNN") out.emplace_back("ambiguity_probability", p);
  }
  if (problem.chi2_alpha_joint && (algo == "JCBB" || algo == "NNJCBB")) {
    out.emplace_back("joint_probability", probabilityText(*problem.chi2_alpha_joint));
  }
  return out;
}

ReplayResult replayAssociation(const AssociationProblem& problem, DataAssociation& associator) {
  problem.validate();
  const std::size_t n = problem.numLandmarks();
  std::vector<LandmarkId> ids(n);
  for (std::size_t k = 0; k < n; ++k) ids[k] = static_cast<LandmarkId>(k);
  EkfSlam ekf;
  ekf.setState(problem.state, problem.covariance, ids);
  LandmarkIndex index;
  index.sync(ekf);
  const RangeBearingModel model(problem.sensor_offset);
  std::vector<Observation> observations(problem.observations.size());
  for (std::size_t i = 0; i < observations.size(); ++i) {
    observations[i].z = problem.observations[i];
    observations[i].R = problem.R;
  }
  const AssociationContext context(ekf, model, index, observations, 0.0);

  ReplayResult out;
  out.result = associator.associate(context);
  out.landmark.assign(observations.size(), -1);
  for (std::size_t i = 0; i < observations.size(); ++i) {
    if (i < out.result.decision.size() && out.result.decision[i] == Decision::kPaired) {
      const int k = ekf.indexOf(out.result.landmark[i]);
      out.landmark[i] = k;
      if (k >= 0) out.pairs.emplace_back(static_cast<int>(i), k);
    }
  }
  out.joint_mahalanobis = context.jointMahalanobis(out.pairs);
  return out;
}

}  // namespace ekf_slam
