#include "ekf_slam/core/association/djnn/static_test.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Cholesky>
#include <Eigen/LU>

namespace ekf_slam {

void StaticTest::read(const ParameterReader& r) {
  const Params def;
  p_.static_test = r.flag("static_test", def.static_test);
  p_.static_probability = r.probability("static_probability", def.static_probability);
  p_.static_heading = r.flag("static_heading", def.static_heading);
  p_.static_min_speed = r.nonNegative("static_min_speed", def.static_min_speed);
  p_.admission_velocity_test = r.flag("admission_velocity_test", def.admission_velocity_test);
  p_.admission_velocity_probability =
      r.probability("admission_velocity_probability", def.admission_velocity_probability);
  p_.fewer_sightings_without_movers =
      r.flag("fewer_sightings_without_movers", def.fewer_sightings_without_movers);
  p_.waive_velocity_test_without_movers =
      r.flag("waive_velocity_test_without_movers", def.waive_velocity_test_without_movers);
  p_.chance_failures_without_movers =
      r.flag("chance_failures_without_movers", def.chance_failures_without_movers);
  p_.sightings_admit_without_movers =
      r.flag("sightings_admit_without_movers", def.sightings_admit_without_movers);
  p_.restarted_sightings = r.flag("restarted_sightings", def.restarted_sightings);
}

void StaticTest::endRestartedRuns(AssociationResult* result) const {
  if (p_.restarted_sightings) return;
  for (const auto& [earlier, run] : result->restarted_features)
    result->ended_features.push_back(earlier);
  result->restarted_features.clear();
}

int StaticTest::sightingsNeeded() const {
  // A static point fails the test by chance in at most 1 - static_probability of its tests; a
  // share below that leaves no room for movers, and then the count only holds landmarks back. A
  // learned mover speed (a mover seen leaving) says movers are here whatever the share.
  return p_.fewer_sightings_without_movers && noMoversSeen() ? 1 : admit_evidence_;
}

bool StaticTest::admitsOnSightings(const Tentative& t) const {
  // Where nothing moves the paper's counter only has clutter to keep out, which never fits one
  // static point admit_evidence times. A camera that misses 3 markers in 10 nets 0.6 per sighting
  // between misses, so the counter alone keeps a marker out for most of its pass.
  return p_.sightings_admit_without_movers && p_.static_test && noMoversSeen() &&
         t.sightings >= admit_evidence_;
}

bool StaticTest::noMoversSeen() const {
  return learned_speed_ <= 0.0 && failure_rate_.moversRuledOut();
}

double StaticTest::minSpeed() const {
  return p_.static_min_speed > 0.0 ? p_.static_min_speed : learned_speed_;
}

double StaticTest::baselineInformation(double v) const {
  if (!(v > 0.0)) return 0.0;
  // An object at speed v has v_hat ~ N(v, J^-1): it fails the velocity test with probability
  // about p when v sqrt(lambda_min(J)) >= sqrt(chi2(2, p)) + z_p (z_p: the standard normal
  // quantile, one-sided along its direction of motion).
  const double q = p_.static_probability;
  const double z = q >= 0.5 ? std::sqrt(chi2Quantile(2.0 * q - 1.0, 1))
                            : -std::sqrt(chi2Quantile(1.0 - 2.0 * q, 1));
  const double k = std::max(0.0, std::sqrt(velocity_gate_) + z) / v;
  return k * k;
}

void StaticTest::configure(int admit_evidence, bool learning, double horizon) {
  admit_evidence_ = admit_evidence;
  learning_ = learning;
  failure_rate_.configure(1.0 - p_.static_probability, horizon);
  static_gate_ =
      Chi2Table(p_.static_probability, 2 * std::max({admit_evidence, 2, kMaxJointSightings}));
  velocity_gate_ = chi2Quantile(p_.static_probability, 2);
  admission_gate_ = chi2Quantile(p_.admission_velocity_probability, 2);
  baseline_information_ = baselineInformation(p_.static_min_speed);
  reset();
}

void StaticTest::beginScan(const Eigen::Matrix3d& P_vv) {
  heading_var_ = p_.static_heading ? std::max(0.0, P_vv(2, 2)) : 0.0;
}

bool StaticTest::stillStatic(Tentative* t, const Eigen::Vector2d& z,
                             const Eigen::Vector2d& heading_lever, const Eigen::Matrix2d& C,
                             double stamp, const AssociationContext* ctx, int obs) {
  if (!p_.static_test) return true;
  // Recursive least-squares residual of the sightings about one static point: the new
  // sighting's normalised distance to the fused position of the earlier ones.
  const Eigen::Vector2d e = z - t->position;
  // A heading error common to the sightings moves each by its lever times the error: they
  // differ by the change of lever (zero without static_heading).
  const Eigen::Vector2d dl = heading_lever - t->heading_lever;
  const double r2 = e.dot((t->cov + C + heading_var_ * dl * dl.transpose()).inverse() * e);
  t->residual += r2;
  ++t->sightings;
  bool moving = t->residual > static_gate_(2 * (t->sightings - 1));
  double joint = 0.0;
  int dof = 0;
  const bool joint_known = ctx != nullptr && jointStatistic(*ctx, *t, obs, &joint, &dof);
  if (joint_known) moving = joint > static_gate_(dof);
  if ((p_.static_min_speed > 0.0 || learning_) && !moving) {
    addToTrack(&t->track_info, &t->track_vec, z, C, stamp, t->first_seen);
    if (minSpeed() > 0.0) {
      // Against a constant velocity (2 dof) rather than any scatter (2 (k - 1) dof): the
      // stronger test for an object moving steadily. At a learned speed the joint fit decides
      // where it can: it holds the pose error the sightings share, which a pose correction
      // would otherwise show as motion.
      Eigen::Matrix2d J;
      Eigen::Vector2d v;
      double v2 = 0.0, residual = 0.0;
      int m = 0;
      if (p_.static_min_speed <= 0.0 && joint_known &&
          jointTrack(*ctx, *t, obs, &v, &J, &residual, &m)) {
        moving = v.dot(J * v) > velocity_gate_;
      } else {
        moving = trackVelocity(*t, &J, &v2) && v2 > velocity_gate_;
      }
    }
  }
  // Judged on the failures before this one: the monitor learns of it either way.
  const bool chance = moving && p_.chance_failures_without_movers && noMoversSeen();
  failure_rate_.tested(moving, stamp);
  if (chance) {
    // A static point fails now and then (1 - static_probability of its tests); where nothing
    // moves a restart only throws its sightings away. Fused, but kept out of the sums and the
    // history the next tests weigh, so that one outlier does not fail them all.
    t->residual -= r2;
    --t->sightings;
    t->chance_failure = true;
    return true;
  }
  return !moving;
}

void StaticTest::record(const AssociationContext& ctx, int obs, Tentative* t) const {
  if (!p_.static_test) return;
  if (t->chance_failure) {  // left out of the joint test (stillStatic)
    t->chance_failure = false;
    return;
  }
  const Observation& o = ctx.observations()[obs];
  if (static_cast<int>(t->history.size()) >= kMaxJointSightings)
    t->history.erase(t->history.begin());
  t->history.push_back({ctx.stamp(), o.z, o.R, o.kind});
}

namespace {

// cov(pose at row a, pose at row b) from the current part of the stored covariance: the lower
// triangle, and each pose's (and clone's) own 3 x 3 block.
Eigen::Matrix3d poseBlock(const ConstMatrixView& P, int a, int b) {
  return a >= b ? Eigen::Matrix3d(P.block<3, 3>(a, b))
                : Eigen::Matrix3d(P.block<3, 3>(b, a).transpose());
}

}  // namespace

struct StaticTest::JointSightings {
  int m = 0;
  Eigen::VectorXd y;
  Eigen::LLT<Eigen::MatrixXd> llt;
  std::vector<double> dt;
};

bool StaticTest::jointSightings(const AssociationContext& ctx, const Tentative& t, int obs,
                                JointSightings* out) const {
  const EkfSlam& ekf = ctx.ekf();
  if (ekf.numClones() == 0 || obs < 0) return false;
  struct Use {
    int row;
    Eigen::Vector2d z;
    Eigen::Matrix2d R;
    MeasurementKind kind;
    double stamp;
  };
  std::vector<Use> uses;
  for (const FeatureSighting& s : t.history) {
    const CloneId c = ekf.findClone(s.stamp);
    if (c != kNoClone) uses.push_back({ekf.cloneRow(c), s.z, s.R, s.kind, s.stamp});
  }
  if (uses.empty()) return false;
  const Observation& o = ctx.observations()[obs];
  uses.push_back({0, o.z, o.R, o.kind, ctx.stamp()});
  const int m = static_cast<int>(uses.size());
  const ConstMatrixView P = ekf.storedCovariance();
  Eigen::VectorXd y(2 * m);
  std::vector<Matrix23d> Gx(m);
  Eigen::MatrixXd S = Eigen::MatrixXd::Zero(2 * m, 2 * m);
  for (int k = 0; k < m; ++k) {
    Eigen::Matrix2d cov;
    y.segment<2>(2 * k) = ctx.sightingPosition(ekf.mean().segment<3>(uses[k].row), uses[k].z,
                                               uses[k].R, uses[k].kind, &Gx[k], &cov);
    S.block<2, 2>(2 * k, 2 * k) = cov;
  }
  for (int k = 0; k < m; ++k) {
    for (int l = 0; l <= k; ++l) {
      const Eigen::Matrix2d b = Gx[k] * poseBlock(P, uses[k].row, uses[l].row) * Gx[l].transpose();
      S.block<2, 2>(2 * k, 2 * l) += b;
      if (l != k) S.block<2, 2>(2 * l, 2 * k) += b.transpose();
    }
  }
  if (!y.allFinite() || !S.allFinite()) return false;
  out->llt.compute(S);
  if (out->llt.info() != Eigen::Success) return false;
  out->m = m;
  out->y = y;
  out->dt.resize(m);
  for (int k = 0; k < m; ++k) out->dt[k] = uses[k].stamp - uses.front().stamp;
  return true;
}

namespace {

// Generalised least squares of y = A x + e, e ~ N(0, S) (llt: S's factor): the residual
// y^T W y - (A^T W y)^T (A^T W A)^-1 (A^T W y), W = S^-1; x's estimate and information A^T W A.
double glsResidual(const Eigen::LLT<Eigen::MatrixXd>& llt, const Eigen::VectorXd& y,
                   const Eigen::MatrixXd& A, Eigen::VectorXd* x, Eigen::MatrixXd* info) {
  const Eigen::MatrixXd WA = llt.solve(A);
  const Eigen::VectorXd Wy = llt.solve(y);
  const Eigen::MatrixXd M = A.transpose() * WA;
  const Eigen::VectorXd b = A.transpose() * Wy;
  const Eigen::VectorXd xhat = M.ldlt().solve(b);
  if (x) *x = xhat;
  if (info) *info = M;
  return y.dot(Wy) - b.dot(xhat);
}

}  // namespace

bool StaticTest::jointStatistic(const AssociationContext& ctx, const Tentative& t, int obs,
                                double* statistic, int* dof) const {
  JointSightings js;
  if (!jointSightings(ctx, t, obs, &js)) return false;
  // One point p for every sighting: y = A p + e, A = [I; I; ...].
  Eigen::MatrixXd A(2 * js.m, 2);
  for (int k = 0; k < js.m; ++k) A.block<2, 2>(2 * k, 0).setIdentity();
  *statistic = glsResidual(js.llt, js.y, A, nullptr, nullptr);
  *dof = 2 * (js.m - 1);
  return std::isfinite(*statistic);
}

bool StaticTest::jointTrack(const AssociationContext& ctx, const Tentative& t, int obs,
                            Eigen::Vector2d* v, Eigen::Matrix2d* J, double* residual,
                            int* m) const {
  JointSightings js;
  if (!jointSightings(ctx, t, obs, &js) || js.m < 3) return false;
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(2 * js.m, 4);
  for (int k = 0; k < js.m; ++k) {
    A.block<2, 2>(2 * k, 0).setIdentity();
    A.block<2, 2>(2 * k, 2) = js.dt[k] * Eigen::Matrix2d::Identity();
  }
  Eigen::VectorXd x;
  Eigen::MatrixXd L;
  *residual = glsResidual(js.llt, js.y, A, &x, &L);
  *v = x.tail<2>();
  // The velocity's information with the position marginalised (Schur complement).
  *J = L.bottomRightCorner<2, 2>() -
       L.bottomLeftCorner<2, 2>() * L.topLeftCorner<2, 2>().inverse() * L.topRightCorner<2, 2>();
  *m = js.m;
  return std::isfinite(*residual) && v->allFinite() && J->allFinite();
}

void StaticTest::started(Tentative* t, const Eigen::Vector2d& z, const Eigen::Matrix2d& C,
                         double stamp) const {
  // While learning the track is kept from the start, so that it is whole once a speed is known.
  if (p_.static_min_speed > 0.0 || learning_) {
    addToTrack(&t->track_info, &t->track_vec, z, C, stamp, t->first_seen);
  }
}

bool StaticTest::admits(const Tentative& t) const {
  // With P_D < 1 a hit is worth more than 1, so T reaches the threshold after fewer sightings
  // than at P_D = 1; the static test still needs the paper's admit_evidence sightings of one
  // static point (and the time they span) to tell a slow mover from a landmark, unless its own
  // failures rule movers out (sightingsNeeded). At P_D = 1, T >= admit_evidence already implies
  // as many sightings since the last restart.
  if (!p_.static_test) return true;
  if (t.sightings < sightingsNeeded()) return false;
  const double v_min = minSpeed();
  if (v_min <= 0.0) return true;
  Eigen::Matrix2d J;
  double v2 = 0.0;
  if (!trackVelocity(t, &J, &v2)) return false;
  // Along the direction the velocity is least known in.
  const double needed =
      p_.static_min_speed > 0.0 ? baseline_information_ : baselineInformation(v_min);
  return leastEigenvalue(J) >= needed;
}

bool StaticTest::movingAtAdmission(const AssociationContext& ctx, const Tentative& t,
                                   int obs) const {
  if (!p_.static_test || !p_.admission_velocity_test) return false;
  // Where nothing moves it only holds landmarks back (docs/djnn.md).
  if (p_.waive_velocity_test_without_movers && noMoversSeen()) return false;
  // One static point (the scatter test, 2 (k - 1) dof) is a weak test against steady motion; a
  // mover that stood still or walked slowly through the admission window passes it. The
  // velocity of the constant-velocity fit (2 dof) is the strong one. Failing it only delays the
  // admission to a later sighting, so it needs no minimum speed, and its gate
  // (admission_velocity_probability) can refuse a static point now and then.
  Eigen::Vector2d v;
  Eigen::Matrix2d J;
  double residual = 0.0;
  int m = 0;
  return jointTrack(ctx, t, obs, &v, &J, &residual, &m) && v.dot(J * v) > admission_gate_;
}

double StaticTest::resolvedSpeed(const Eigen::Matrix4d& track_info) const {
  const Eigen::Matrix2d J = velocityInformation(track_info);
  if (!determined(J)) return std::numeric_limits<double>::infinity();
  const double lambda = leastEigenvalue(J);
  if (!(lambda > 0.0)) return std::numeric_limits<double>::infinity();
  return std::sqrt(baselineInformation(1.0) / lambda);
}

// Weighted least squares of z_i = p + (t_i - t_0) v + e_i, e_i ~ N(0, C_i), in information form.
void StaticTest::addToTrack(Eigen::Matrix4d* track_info, Eigen::Vector4d* track_vec,
                            const Eigen::Vector2d& z, const Eigen::Matrix2d& C, double stamp,
                            double first_seen) {
  const double dt = stamp - first_seen;
  const Eigen::Matrix2d W = C.inverse();
  track_info->topLeftCorner<2, 2>() += W;
  track_info->topRightCorner<2, 2>() += dt * W;
  track_info->bottomLeftCorner<2, 2>() += dt * W;
  track_info->bottomRightCorner<2, 2>() += dt * dt * W;
  if (track_vec == nullptr) return;
  const Eigen::Vector2d wz = W * z;
  track_vec->head<2>() += wz;
  track_vec->tail<2>() += dt * wz;
}

Eigen::Matrix2d StaticTest::velocityInformation(const Eigen::Matrix4d& L) {
  const Eigen::Matrix2d Lpp_inv = L.topLeftCorner<2, 2>().inverse();
  const Eigen::Matrix2d Lvp = L.bottomLeftCorner<2, 2>();
  return L.bottomRightCorner<2, 2>() - Lvp * Lpp_inv * Lvp.transpose();
}

double StaticTest::leastEigenvalue(const Eigen::Matrix2d& J) {
  const double half_trace = 0.5 * J.trace();
  const double gap = std::sqrt(std::max(0.0, half_trace * half_trace - J.determinant()));
  return half_trace - gap;
}

bool StaticTest::determined(const Eigen::Matrix2d& J) {
  // All sightings at one stamp (or one): no velocity information yet.
  return J.determinant() > 1e-12 * J.squaredNorm() && J.trace() > 0.0;
}

bool StaticTest::trackVelocity(const Tentative& t, Eigen::Matrix2d* J, double* statistic) {
  // Position marginalised out (Schur complement): J = L_vv - L_vp L_pp^-1 L_pv, and
  // v_hat = J^-1 b with b = y_v - L_vp L_pp^-1 y_p, so v_hat^T J v_hat = b^T J^-1 b.
  const Eigen::Matrix2d Lpp_inv = t.track_info.topLeftCorner<2, 2>().inverse();
  const Eigen::Matrix2d Lvp = t.track_info.bottomLeftCorner<2, 2>();
  *J = velocityInformation(t.track_info);
  const Eigen::Vector2d b = t.track_vec.tail<2>() - Lvp * Lpp_inv * t.track_vec.head<2>();
  if (!determined(*J)) return false;
  *statistic = b.dot(J->inverse() * b);
  return std::isfinite(*statistic);
}

}  // namespace ekf_slam
