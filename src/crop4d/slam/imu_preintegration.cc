#include "crop4d/slam/imu_preintegration.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "crop4d/geometry/rotation.h"

namespace crop4d::slam {
namespace {

using geometry::ExpSO3;
using geometry::Hat;
using geometry::LogSO3;
using geometry::RightJacobianInverseSO3;
using geometry::RightJacobianSO3;

void InterpolateSample(const std::vector<ImuSample>& samples, Timestamp t, Eigen::Vector3d* gyro,
                       Eigen::Vector3d* accel) {
  if (t <= samples.front().timestamp) {
    *gyro = samples.front().gyro_body;
    *accel = samples.front().accel_body;
    return;
  }
  if (t >= samples.back().timestamp) {
    *gyro = samples.back().gyro_body;
    *accel = samples.back().accel_body;
    return;
  }
  const auto upper =
      std::upper_bound(samples.begin(), samples.end(), t,
                       [](Timestamp a, const ImuSample& s) { return a < s.timestamp; });
  const ImuSample& s1 = *upper;
  const ImuSample& s0 = *(upper - 1);
  const double span = DurationSeconds(s0.timestamp, s1.timestamp);
  const double alpha = span > 0.0 ? DurationSeconds(s0.timestamp, t) / span : 0.0;
  *gyro = (1.0 - alpha) * s0.gyro_body + alpha * s1.gyro_body;
  *accel = (1.0 - alpha) * s0.accel_body + alpha * s1.accel_body;
}

}  // namespace

ImuSample InterpolateImu(const std::vector<ImuSample>& samples, Timestamp t) {
  if (samples.empty()) throw std::invalid_argument("InterpolateImu: no samples");
  ImuSample sample;
  sample.timestamp = t;
  InterpolateSample(samples, t, &sample.gyro_body, &sample.accel_body);
  return sample;
}

OptionCheck ImuPreintegration::Options::Check() const {
  OptionChecker c;
  c.Greater("gyro_noise_density", gyro_noise_density, 0.0)
      .Greater("accel_noise_density", accel_noise_density, 0.0)
      .Greater("gyro_random_walk", gyro_random_walk, 0.0)
      .Greater("accel_random_walk", accel_random_walk, 0.0)
      .Greater("gravity", gravity, 0.0)
      .AtLeast("covariance_regularisation", covariance_regularisation, 0.0);
  return c.Result();
}

ImuPreintegration::ImuPreintegration(const Options& options, const Vector6d& bias_linearisation)
    : options_(options), bias_(bias_linearisation) {
  if (const OptionCheck why = options_.Check(); !why.empty()) {
    throw std::invalid_argument("ImuPreintegration: " + why);
  }
}

void ImuPreintegration::Reset() {
  delta_time_ = 0.0;
  delta_rotation_.setIdentity();
  delta_velocity_.setZero();
  delta_position_.setZero();
  covariance_.setZero();
  bias_jacobian_.setZero();
}

void ImuPreintegration::Integrate(const std::vector<ImuSample>& samples, Timestamp t_i,
                                  Timestamp t_j) {
  if (samples.empty()) throw std::invalid_argument("ImuPreintegration::Integrate: no samples");
  if (t_j < t_i) throw std::invalid_argument("ImuPreintegration::Integrate: t_j < t_i");
  // Breakpoints: t_i, every sample time strictly inside (t_i, t_j), t_j.
  std::vector<Timestamp> breaks;
  breaks.push_back(t_i);
  // Samples are sorted: binary search for the first one after t_i.
  auto it = std::upper_bound(samples.begin(), samples.end(), t_i,
                             [](Timestamp t, const ImuSample& s) { return t < s.timestamp; });
  for (; it != samples.end() && it->timestamp < t_j; ++it) breaks.push_back(it->timestamp);
  breaks.push_back(t_j);
  Eigen::Vector3d gyro_a, accel_a, gyro_b, accel_b;
  InterpolateSample(samples, breaks.front(), &gyro_a, &accel_a);
  for (size_t k = 1; k < breaks.size(); ++k) {
    InterpolateSample(samples, breaks[k], &gyro_b, &accel_b);
    const double dt = DurationSeconds(breaks[k - 1], breaks[k]);
    // Mean of the linear signal over the sub-interval.
    if (dt > 0.0) IntegrateStep(0.5 * (gyro_a + gyro_b), 0.5 * (accel_a + accel_b), dt);
    gyro_a = gyro_b;
    accel_a = accel_b;
  }
}

void ImuPreintegration::IntegrateStep(const Eigen::Vector3d& gyro_body,
                                      const Eigen::Vector3d& accel_body, double dt) {
  const Eigen::Vector3d omega = gyro_body - bias_.head<3>();
  const Eigen::Vector3d accel = accel_body - bias_.tail<3>();
  const Eigen::Matrix3d E = ExpSO3(omega * dt);
  const Eigen::Matrix3d E_half = ExpSO3(0.5 * omega * dt);
  const Eigen::Matrix3d R_half = delta_rotation_ * E_half;
  const Eigen::Matrix3d J_half = RightJacobianSO3(0.5 * omega * dt);
  const Eigen::Matrix3d Ra_hat = R_half * Hat(accel);
  const double dt2 = dt * dt;

  // Error-state transition and input matrices of the midpoint step (file comment of the header).
  Matrix9d A = Matrix9d::Identity();
  A.block<3, 3>(0, 0) = E.transpose();
  A.block<3, 3>(3, 0) = -Ra_hat * E_half.transpose() * dt;
  A.block<3, 3>(6, 0) = -0.5 * Ra_hat * E_half.transpose() * dt2;
  A.block<3, 3>(6, 3) = Eigen::Matrix3d::Identity() * dt;
  Eigen::Matrix<double, 9, 3> B_g, B_a;
  B_g.block<3, 3>(0, 0) = RightJacobianSO3(omega * dt) * dt;
  B_g.block<3, 3>(3, 0) = -Ra_hat * J_half * (0.5 * dt2);
  B_g.block<3, 3>(6, 0) = -Ra_hat * J_half * (0.25 * dt2 * dt);
  B_a.block<3, 3>(0, 0).setZero();
  B_a.block<3, 3>(3, 0) = R_half * dt;
  B_a.block<3, 3>(6, 0) = 0.5 * R_half * dt2;

  // Continuous → discrete noise: σ_d² = σ²/δt (Forster §VI-B).
  const double var_g = options_.gyro_noise_density * options_.gyro_noise_density / dt;
  const double var_a = options_.accel_noise_density * options_.accel_noise_density / dt;
  covariance_ = A * covariance_ * A.transpose() + var_g * B_g * B_g.transpose() +
                var_a * B_a * B_a.transpose();
  Eigen::Matrix<double, 9, 6> B;
  B << B_g, B_a;
  bias_jacobian_ = A * bias_jacobian_ - B;

  delta_position_ += delta_velocity_ * dt + 0.5 * R_half * accel * dt2;
  delta_velocity_ += R_half * accel * dt;
  delta_rotation_ = delta_rotation_ * E;
  // Keep ΔR orthonormal over long integrations.
  delta_rotation_ = Eigen::Quaterniond(delta_rotation_).normalized().toRotationMatrix();
  delta_time_ += dt;
}

Eigen::Matrix3d ImuPreintegration::CorrectedDeltaRotation(const Vector6d& bias) const {
  const Vector6d db = bias - bias_;
  return delta_rotation_ * ExpSO3(dR_dbg() * db.head<3>());
}

Eigen::Vector3d ImuPreintegration::CorrectedDeltaVelocity(const Vector6d& bias) const {
  const Vector6d db = bias - bias_;
  return delta_velocity_ + dv_dbg() * db.head<3>() + dv_dba() * db.tail<3>();
}

Eigen::Vector3d ImuPreintegration::CorrectedDeltaPosition(const Vector6d& bias) const {
  const Vector6d db = bias - bias_;
  return delta_position_ + dp_dbg() * db.head<3>() + dp_dba() * db.tail<3>();
}

NavState ImuPreintegration::Predict(const NavState& state_i, const Vector6d& bias) const {
  const Eigen::Matrix3d R_i = state_i.world_from_body_rotation.toRotationMatrix();
  const Eigen::Vector3d g = gravity_world();
  const double T = delta_time_;
  NavState state_j;
  state_j.world_from_body_rotation =
      Eigen::Quaterniond(R_i * CorrectedDeltaRotation(bias)).normalized();
  state_j.vel_world = state_i.vel_world + g * T + R_i * CorrectedDeltaVelocity(bias);
  state_j.position_world = state_i.position_world + state_i.vel_world * T + 0.5 * g * T * T +
                           R_i * CorrectedDeltaPosition(bias);
  return state_j;
}

// ---------------------------------------------------------------------------------------------

ImuFactor::ImuFactor(const ImuPreintegration& preintegration) : preintegration_(preintegration) {
  const Matrix9d covariance =
      preintegration.covariance() +
      preintegration.options().covariance_regularisation * Matrix9d::Identity();
  const Matrix9d information = covariance.inverse();
  // information = L Lᵀ, S = Lᵀ so that Sᵀ S = Σ⁻¹.
  sqrt_information_ = information.llt().matrixL().transpose();
}

ceres::CostFunction* ImuFactor::Create(const ImuPreintegration& preintegration) {
  return new ImuFactor(preintegration);
}

Vector9d ImuFactor::UnweightedResidual(const double* pose_i, const double* vel_i,
                                       const double* bias_i, const double* pose_j,
                                       const double* vel_j) const {
  Vector9d r;
  const double* parameters[5] = {pose_i, vel_i, bias_i, pose_j, vel_j};
  // Evaluate without weighting: reuse Evaluate and undo S (S is triangular and invertible).
  Vector9d weighted;
  Evaluate(parameters, weighted.data(), nullptr);
  r = sqrt_information_.triangularView<Eigen::Upper>().solve(weighted);
  return r;
}

bool ImuFactor::Evaluate(double const* const* parameters, double* residuals,
                         double** jacobians) const {
  const Eigen::Map<const Eigen::Vector3d> p_i(parameters[0]);
  const Eigen::Map<const Eigen::Quaterniond> q_i(parameters[0] + 3);
  const Eigen::Map<const Eigen::Vector3d> v_i(parameters[1]);
  const Eigen::Map<const Vector6d> b_i(parameters[2]);
  const Eigen::Map<const Eigen::Vector3d> p_j(parameters[3]);
  const Eigen::Map<const Eigen::Quaterniond> q_j(parameters[3] + 3);
  const Eigen::Map<const Eigen::Vector3d> v_j(parameters[4]);

  const ImuPreintegration& pre = preintegration_;
  const double T = pre.delta_time();
  const Eigen::Vector3d g = pre.gravity_world();
  const Vector6d db = b_i - pre.bias_linearisation();
  const Eigen::Vector3d dbg = db.head<3>();
  const Eigen::Matrix3d R_i = q_i.normalized().toRotationMatrix();
  const Eigen::Matrix3d R_j = q_j.normalized().toRotationMatrix();
  const Eigen::Matrix3d Rt_i = R_i.transpose();

  const Eigen::Vector3d bias_rot = pre.dR_dbg() * dbg;
  const Eigen::Matrix3d dR_corrected = pre.delta_rotation() * ExpSO3(bias_rot);
  const Eigen::Vector3d a = v_j - v_i - g * T;
  const Eigen::Vector3d d = p_j - p_i - v_i * T - 0.5 * g * T * T;

  Vector9d r;
  const Eigen::Vector3d r_R = LogSO3(dR_corrected.transpose() * Rt_i * R_j);
  r.segment<3>(0) = r_R;
  r.segment<3>(3) = Rt_i * a - pre.CorrectedDeltaVelocity(b_i);
  r.segment<3>(6) = Rt_i * d - pre.CorrectedDeltaPosition(b_i);
  (Eigen::Map<Vector9d>(residuals)) = sqrt_information_ * r;

  if (jacobians == nullptr) return true;
  const Eigen::Matrix3d Jr_inv = RightJacobianInverseSO3(r_R);
  const Matrix9d& S = sqrt_information_;

  if (jacobians[0] != nullptr) {  // pose_i: [δp_i, δφ_i]
    Eigen::Matrix<double, 9, 6> J = Eigen::Matrix<double, 9, 6>::Zero();
    J.block<3, 3>(0, 3) = -Jr_inv * R_j.transpose() * R_i;
    J.block<3, 3>(3, 3) = Hat(Rt_i * a);
    J.block<3, 3>(6, 0) = -Rt_i;
    J.block<3, 3>(6, 3) = Hat(Rt_i * d);
    const Eigen::Matrix<double, 9, 6> SJ = S * J;
    WritePoseJacobian<9>(SJ, parameters[0], jacobians[0]);
  }
  if (jacobians[1] != nullptr) {  // vel_i
    Eigen::Matrix<double, 9, 3> J = Eigen::Matrix<double, 9, 3>::Zero();
    J.block<3, 3>(3, 0) = -Rt_i;
    J.block<3, 3>(6, 0) = -Rt_i * T;
    (Eigen::Map<Eigen::Matrix<double, 9, 3, Eigen::RowMajor>>(jacobians[1])) = S * J;
  }
  if (jacobians[2] != nullptr) {  // bias_i = [bg; ba]
    Eigen::Matrix<double, 9, 6> J = Eigen::Matrix<double, 9, 6>::Zero();
    J.block<3, 3>(0, 0) =
        -Jr_inv * ExpSO3(r_R).transpose() * RightJacobianSO3(bias_rot) * pre.dR_dbg();
    J.block<3, 3>(3, 0) = -pre.dv_dbg();
    J.block<3, 3>(3, 3) = -pre.dv_dba();
    J.block<3, 3>(6, 0) = -pre.dp_dbg();
    J.block<3, 3>(6, 3) = -pre.dp_dba();
    (Eigen::Map<Eigen::Matrix<double, 9, 6, Eigen::RowMajor>>(jacobians[2])) = S * J;
  }
  if (jacobians[3] != nullptr) {  // pose_j
    Eigen::Matrix<double, 9, 6> J = Eigen::Matrix<double, 9, 6>::Zero();
    J.block<3, 3>(0, 3) = Jr_inv;
    J.block<3, 3>(6, 0) = Rt_i;
    const Eigen::Matrix<double, 9, 6> SJ = S * J;
    WritePoseJacobian<9>(SJ, parameters[3], jacobians[3]);
  }
  if (jacobians[4] != nullptr) {  // vel_j
    Eigen::Matrix<double, 9, 3> J = Eigen::Matrix<double, 9, 3>::Zero();
    J.block<3, 3>(3, 0) = Rt_i;
    (Eigen::Map<Eigen::Matrix<double, 9, 3, Eigen::RowMajor>>(jacobians[4])) = S * J;
  }
  return true;
}

// ---------------------------------------------------------------------------------------------

BiasRandomWalkFactor::BiasRandomWalkFactor(double gyro_random_walk, double accel_random_walk,
                                           double dt) {
  if (!(gyro_random_walk > 0.0 && accel_random_walk > 0.0 && dt > 0.0)) {
    throw std::invalid_argument("BiasRandomWalkFactor: random walks and dt must be positive");
  }
  const double sqrt_dt = std::sqrt(dt);
  sqrt_information_diagonal_.head<3>().setConstant(1.0 / (gyro_random_walk * sqrt_dt));
  sqrt_information_diagonal_.tail<3>().setConstant(1.0 / (accel_random_walk * sqrt_dt));
}

ceres::CostFunction* BiasRandomWalkFactor::Create(double gyro_random_walk, double accel_random_walk,
                                                  double dt) {
  return new BiasRandomWalkFactor(gyro_random_walk, accel_random_walk, dt);
}

bool BiasRandomWalkFactor::Evaluate(double const* const* parameters, double* residuals,
                                    double** jacobians) const {
  const Eigen::Map<const Vector6d> b_i(parameters[0]);
  const Eigen::Map<const Vector6d> b_j(parameters[1]);
  (Eigen::Map<Vector6d>(residuals)) = sqrt_information_diagonal_.cwiseProduct(b_j - b_i);
  if (jacobians == nullptr) return true;
  const Matrix6d S = sqrt_information_diagonal_.asDiagonal();
  if (jacobians[0] != nullptr)
    (Eigen::Map<Eigen::Matrix<double, 6, 6, Eigen::RowMajor>>(jacobians[0])) = -S;
  if (jacobians[1] != nullptr)
    (Eigen::Map<Eigen::Matrix<double, 6, 6, Eigen::RowMajor>>(jacobians[1])) = S;
  return true;
}

// ---------------------------------------------------------------------------------------------

AngularRateFactor::AngularRateFactor(const Eigen::Vector3d& gyro_body, double sigma_rate)
    : gyro_body_(gyro_body) {
  if (!(sigma_rate > 0.0)) throw std::invalid_argument("AngularRateFactor: sigma must be > 0");
  inv_sigma_ = 1.0 / sigma_rate;
}

ceres::CostFunction* AngularRateFactor::Create(const Eigen::Vector3d& gyro_body,
                                               double sigma_rate) {
  return new AngularRateFactor(gyro_body, sigma_rate);
}

bool AngularRateFactor::Evaluate(double const* const* parameters, double* residuals,
                                 double** jacobians) const {
  const Eigen::Map<const Eigen::Vector3d> rate_body(parameters[0]);
  const Eigen::Map<const Eigen::Vector3d> bias_gyro(parameters[1]);
  Eigen::Map<Eigen::Vector3d> r(residuals);
  r = inv_sigma_ * (rate_body - (gyro_body_ - bias_gyro));
  if (jacobians == nullptr) return true;
  if (jacobians[0] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> J(jacobians[0]);
    J = inv_sigma_ * Eigen::Matrix3d::Identity();
  }
  if (jacobians[1] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 3, 6, Eigen::RowMajor>> J(jacobians[1]);
    J.setZero();
    J.leftCols<3>() = inv_sigma_ * Eigen::Matrix3d::Identity();
  }
  return true;
}

}  // namespace crop4d::slam
