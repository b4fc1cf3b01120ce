#pragma once

// On-manifold IMU preintegration and the Ceres IMU and bias random-walk factors (DESIGN.md §2.2),
// after Forster, Carlone, Dellaert, Scaramuzza, "On-Manifold Preintegration for Real-Time
// Visual-Inertial Odometry", T-RO 2017 (RSS 2015), §V–VI. State layout: state_layout.h.
//
// Measurement model (Forster §V): gyro ω̃ = ω_body + bg + ηg, accel
// ã = R_world_bodyᵀ (a_world − g_world) + ba + ηa, with g_world = (0, 0, −g) (ENU).
// Preintegrated quantities between state times t_i and t_j (Forster §VI-A):
//   ΔR_ij = ∏ Exp((ω̃_k − bg) δt_k)
//   Δv_ij = Σ ΔR_ik (ã_k − ba) δt_k
//   Δp_ij = Σ Δv_ik δt_k + ½ ΔR_ik (ã_k − ba) δt_k²
// so that R_j = R_i ΔR_ij, v_j = v_i + g Δt + R_i Δv_ij, p_j = p_i + v_i Δt + ½ g Δt² + R_i Δp_ij.
//
// Integration scheme (second order, our refinement of Forster's Euler steps): the IMU signal is
// the linear interpolation of the samples (held constant before the first and after the last
// sample). The interval [t_i, t_j] is cut at every sample time inside it, so the first and last
// sub-intervals are partial when the image times fall between IMU samples. On each
// sub-interval [a, b] the step uses the mean of the interpolated signal (exact for a
// piecewise-linear signal) and rotates the acceleration with the mid-step rotation
// ΔR_k Exp(ω δt/2) (midpoint rule):
//   ΔR_{k+1} = ΔR_k Exp(ω δt),   Δv_{k+1} = Δv_k + R_h a δt,
//   Δp_{k+1} = Δp_k + Δv_k δt + ½ R_h a δt²,
// with R_h = ΔR_k Exp(ω δt/2). Forster's Euler step (R_h = ΔR_k) is first order and drifts by
// centimetres over a 2 s IMU-only chain; the midpoint step does not.
//
// Error state δ = [δφ; δv; δp] (ΔR ← ΔR Exp(δφ), Δv ← Δv + δv, Δp ← Δp + δp). Linearising the
// step above in δ and in input perturbations δω, δa (Forster App. A does this for the Euler step;
// E = Exp(ω δt), E_h = Exp(ω δt/2), J_h = Jr(ω δt/2)):
//   A   = [Eᵀ, 0, 0;  −R_h [a]× E_hᵀ δt, I, 0;  −½ R_h [a]× E_hᵀ δt², I δt, I]
//   B_g = [Jr(ω δt) δt;  −R_h [a]× J_h δt²/2;  −R_h [a]× J_h δt³/4]
//   B_a = [0;  R_h δt;  ½ R_h δt²]
// Covariance (Forster §VI-B and App. A): Σ ← A Σ Aᵀ + B_g Σ_gd B_gᵀ + B_a Σ_ad B_aᵀ, with the
// discrete noise Σ_gd = σ_g²/δt I, Σ_ad = σ_a²/δt I (σ continuous-time noise densities). Bias
// Jacobians J = d[δφ; δv; δp]/d[bg; ba] (9×6; Forster §VI-C and App. B): a bias change enters as δω
// = −δbg, δa = −δba, so J ← A J − [B_g B_a]. Its blocks are dR/dbg (rows 0–2, cols 0–2; dR/dba =
// 0), dv/dbg, dv/dba, dp/dbg, dp/dba. Bias correction to first order (Forster §VI-C): ΔR(b) = ΔR
// Exp(dR/dbg δbg), Δv(b) = Δv + dv/dbg δbg + dv/dba δba, Δp(b) = Δp + dp/dbg δbg + dp/dba δba, δb =
// b − b̄.

#include <ceres/sized_cost_function.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/core/timestamp.h"
#include "crop4d/slam/state_layout.h"

namespace crop4d::slam {

// One IMU sample in the body (IMU) frame (EuRoC imu0/data.csv).
struct ImuSample {
  Timestamp timestamp = 0;
  // Angular rate, rad/s.
  Eigen::Vector3d gyro_body = Eigen::Vector3d::Zero();
  // Specific force, m/s².
  Eigen::Vector3d accel_body = Eigen::Vector3d::Zero();
};

// The IMU signal at time t: linear interpolation of the (time-sorted, non-empty) samples, held
// constant before the first and after the last one.
ImuSample InterpolateImu(const std::vector<ImuSample>& samples, Timestamp t);

// Navigation state used to predict and to test the preintegration.
struct NavState {
  Eigen::Quaterniond world_from_body_rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d position_world = Eigen::Vector3d::Zero();
  Eigen::Vector3d vel_world = Eigen::Vector3d::Zero();
};

class ImuPreintegration {
 public:
  struct Options {
    // Gyroscope white-noise density σ_g, rad/s/√Hz (EuRoC gyroscope_noise_density).
    double gyro_noise_density = 1.7e-4;
    // Accelerometer white-noise density σ_a, m/s²/√Hz (accelerometer_noise_density).
    double accel_noise_density = 2.0e-3;
    // Gyroscope bias random walk, rad/s²/√Hz (gyroscope_random_walk).
    double gyro_random_walk = 1.9e-5;
    // Accelerometer bias random walk, m/s³/√Hz (accelerometer_random_walk).
    double accel_random_walk = 3.0e-3;
    // Magnitude of gravity, m/s²; g_world = (0, 0, −gravity) in ENU.
    double gravity = 9.81;
    // Added to the diagonal of the covariance before it is inverted (guards very short
    // intervals, where the covariance is nearly singular).
    double covariance_regularisation = 1e-12;

    OptionCheck Check() const;
  };

  ImuPreintegration() = default;
  // bias_linearisation = [bg; ba], the bias b̄ at which the samples are integrated.
  ImuPreintegration(const Options& options, const Vector6d& bias_linearisation);

  // Starts over with zero deltas at the same bias.
  void Reset();
  // Integrates the samples over [t_i, t_j] (scheme in the file comment; samples sorted by
  // time; they may start before t_i and end after t_j). Appends to what was integrated before,
  // so consecutive calls over adjacent intervals compose. Needs at least one sample.
  void Integrate(const std::vector<ImuSample>& samples, Timestamp t_i, Timestamp t_j);
  // One step with constant raw measurements over dt seconds (bias b̄ subtracted here).
  void IntegrateStep(const Eigen::Vector3d& gyro_body, const Eigen::Vector3d& accel_body,
                     double dt);

  const Options& options() const { return options_; }
  const Vector6d& bias_linearisation() const { return bias_; }
  // Σ δt_k, seconds.
  double delta_time() const { return delta_time_; }
  const Eigen::Matrix3d& delta_rotation() const { return delta_rotation_; }
  const Eigen::Vector3d& delta_velocity() const { return delta_velocity_; }
  const Eigen::Vector3d& delta_position() const { return delta_position_; }
  // Covariance of [δφ; δv; δp].
  const Matrix9d& covariance() const { return covariance_; }
  // d[δφ; δv; δp]/d[bg; ba] at b̄.
  const Eigen::Matrix<double, 9, 6>& bias_jacobian() const { return bias_jacobian_; }
  Eigen::Matrix3d dR_dbg() const { return bias_jacobian_.block<3, 3>(0, 0); }
  Eigen::Matrix3d dv_dbg() const { return bias_jacobian_.block<3, 3>(3, 0); }
  Eigen::Matrix3d dv_dba() const { return bias_jacobian_.block<3, 3>(3, 3); }
  Eigen::Matrix3d dp_dbg() const { return bias_jacobian_.block<3, 3>(6, 0); }
  Eigen::Matrix3d dp_dba() const { return bias_jacobian_.block<3, 3>(6, 3); }
  Eigen::Vector3d gravity_world() const { return Eigen::Vector3d(0, 0, -options_.gravity); }

  // First-order bias-corrected deltas (Forster §VI-C) at bias = [bg; ba].
  Eigen::Matrix3d CorrectedDeltaRotation(const Vector6d& bias) const;
  Eigen::Vector3d CorrectedDeltaVelocity(const Vector6d& bias) const;
  Eigen::Vector3d CorrectedDeltaPosition(const Vector6d& bias) const;

  // State at t_j from the state at t_i (the relations of Forster §VI-A solved for state j).
  NavState Predict(const NavState& state_i, const Vector6d& bias) const;

 private:
  Options options_;
  Vector6d bias_ = Vector6d::Zero();
  double delta_time_ = 0.0;
  Eigen::Matrix3d delta_rotation_ = Eigen::Matrix3d::Identity();
  Eigen::Vector3d delta_velocity_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d delta_position_ = Eigen::Vector3d::Zero();
  Matrix9d covariance_ = Matrix9d::Zero();
  Eigen::Matrix<double, 9, 6> bias_jacobian_ = Eigen::Matrix<double, 9, 6>::Zero();
};

// IMU factor between states i and j (Forster §VI-D). Parameter blocks:
// pose_i[7], vel_i[3], bias_i[6], pose_j[7], vel_j[3]. With δb = b_i − b̄:
//   r_R = Log( (ΔR Exp(dR/dbg δbg))ᵀ R_iᵀ R_j )
//   r_v = R_iᵀ (v_j − v_i − g Δt) − (Δv + dv/dbg δbg + dv/dba δba)
//   r_p = R_iᵀ (p_j − p_i − v_i Δt − ½ g Δt²) − (Δp + dp/dbg δbg + dp/dba δba)
// weighted by S with Sᵀ S = Σ⁻¹ (upper Cholesky factor of the information matrix).
// Jacobians (right perturbation R ← R Exp(δφ), p ← p + δp; Forster App. C with world-frame
// position increments), Jr⁻¹ = Jr⁻¹(r_R), a = v_j − v_i − gΔt, d = p_j − p_i − v_i Δt − ½gΔt²:
//   ∂r_R/∂φ_i = −Jr⁻¹ R_jᵀ R_i      ∂r_R/∂φ_j = Jr⁻¹
//   ∂r_R/∂bg  = −Jr⁻¹ Exp(r_R)ᵀ Jr(dR/dbg δbg) dR/dbg
//   ∂r_v/∂φ_i = [R_iᵀ a]×   ∂r_v/∂v_i = −R_iᵀ   ∂r_v/∂v_j = R_iᵀ   ∂r_v/∂b = −[dv/dbg dv/dba]
//   ∂r_p/∂φ_i = [R_iᵀ d]×   ∂r_p/∂p_i = −R_iᵀ   ∂r_p/∂p_j = R_iᵀ   ∂r_p/∂v_i = −R_iᵀ Δt
//   ∂r_p/∂b   = −[dp/dbg dp/dba].
class ImuFactor final : public ceres::SizedCostFunction<9, 7, 3, 6, 7, 3> {
 public:
  explicit ImuFactor(const ImuPreintegration& preintegration);
  static ceres::CostFunction* Create(const ImuPreintegration& preintegration);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

  // The unweighted residual [r_R; r_v; r_p] (for tests and diagnostics).
  Vector9d UnweightedResidual(const double* pose_i, const double* vel_i, const double* bias_i,
                              const double* pose_j, const double* vel_j) const;
  const Matrix9d& sqrt_information() const { return sqrt_information_; }

 private:
  ImuPreintegration preintegration_;
  Matrix9d sqrt_information_;
};

// Bias random walk between bias_i[6] and bias_j[6] (Forster §VI-E):
//   r = S (b_j − b_i),  S = diag(1/(σ_bg √Δt) I₃, 1/(σ_ba √Δt) I₃),
// since integrating white noise of density σ over Δt gives a variance σ² Δt.
// ∂r/∂b_i = −S, ∂r/∂b_j = S.
class BiasRandomWalkFactor final : public ceres::SizedCostFunction<6, 6, 6> {
 public:
  BiasRandomWalkFactor(double gyro_random_walk, double accel_random_walk, double dt);
  static ceres::CostFunction* Create(double gyro_random_walk, double accel_random_walk, double dt);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Vector6d sqrt_information_diagonal_;
};

// Angular-rate factor tying a state's rate_body[3] to the gyroscope at the state's time (the GP
// prior, gp_prior.h, is the only other factor on the rate). Parameter blocks: rate[3],
// bias[6] (bg, ba). With the interpolated gyro sample ω̃(t) (InterpolateImu):
//   r = (ω − (ω̃ − bg)) / σ_ω,   σ_ω = σ_g √f_imu  (discrete noise of one sample, Forster §V),
//   ∂r/∂ω = I/σ_ω,   ∂r/∂b = [I/σ_ω, 0].
class AngularRateFactor final : public ceres::SizedCostFunction<3, 3, 6> {
 public:
  AngularRateFactor(const Eigen::Vector3d& gyro_body, double sigma_rate);
  // sigma_rate = gyro_noise_density · √(IMU rate in Hz), rad/s.
  static ceres::CostFunction* Create(const Eigen::Vector3d& gyro_body, double sigma_rate);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Eigen::Vector3d gyro_body_;
  double inv_sigma_;
};

}  // namespace crop4d::slam
