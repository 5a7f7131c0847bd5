#pragma once
// The "fly-by-wire" inner loop: AeroBench's LowLevelController (gain set 'old') and the
// closed-loop derivative of highlevel/controlled_f16.py. Two decoupled LQR regulators with
// integral action track the outer-loop references [Nz_ref, ps_ref, Ny_r_ref, throttle delta].
#include "dynamics/plant.hpp"

namespace f16race::dynamics {

// Linearisation point and gains, AeroBench lowlevel/low_level_controller.py.
namespace lqr {
inline constexpr double kAlphaEquil_rad = 0.0389;  // xequil[1]; xequil's q, beta, p, r are 0
inline constexpr double kThrottleEquil = 0.1395;   // uequil[0]
inline constexpr double kElevatorEquil_deg = -0.7496;
// Longitudinal row, acting on [alpha - alpha_equil, q, int_e_Nz].
inline constexpr double kLong[3] = {-156.8801506723475, -31.037008068526642, -38.72983346216317};
// Lateral rows (aileron, rudder), acting on [beta, p, r, int_e_ps, int_e_Ny_r].
inline constexpr double kLatAileron[5] = {37.84483, -25.40956, -6.82876, -332.88343, -17.15997};
inline constexpr double kLatRudder[5] = {-23.91233, 5.69968, -21.63431, 64.49490, -88.36203};
// Saturation limits (CtrlLimits). No rate limits or actuator dynamics, as in AeroBench.
inline constexpr double kElevatorMax_deg = 25.0;
inline constexpr double kAileronMax_deg = 21.5;
inline constexpr double kRudderMax_deg = 30.0;
// Range of Nz_ref that AeroBench's get_checked_u_ref accepts.
inline constexpr double kNzRefMin_g = -1.0;
inline constexpr double kNzRefMax_g = 6.0;
// The equilibrium state AeroBench's LQR was designed at (Stevens trim, 502 ft/s, 1000 ft).
inline constexpr double kXequil[kNumPlantStates] = {502.0, 0.0389, 0.0, 0.0, 0.0389, 0.0, 0.0,
                                                     0.0,   0.0,    0.0, 0.0, 1000.0, 9.0567};
}  // namespace lqr

F16_INLINE double clamp_value(double v, double lo, double hi) { return (v > hi) ? hi : ((v < lo) ? lo : v); }

// LQR surface commands after saturation for state x (16) and references u_ref (4).
F16_INLINE SurfaceCommands inner_loop_commands(const double* x, const double* u_ref) {
  using namespace lqr;
  const double da = x[kAlpha] - kAlphaEquil_rad;
  const double el = -(kLong[0] * da + kLong[1] * x[kQ] + kLong[2] * x[kIntNz]);
  const double ail = -(kLatAileron[0] * x[kBeta] + kLatAileron[1] * x[kP] + kLatAileron[2] * x[kR] +
                       kLatAileron[3] * x[kIntPs] + kLatAileron[4] * x[kIntNyR]);
  const double rdr = -(kLatRudder[0] * x[kBeta] + kLatRudder[1] * x[kP] + kLatRudder[2] * x[kR] +
                       kLatRudder[3] * x[kIntPs] + kLatRudder[4] * x[kIntNyR]);
  SurfaceCommands u;
  u.throttle = clamp_value(u_ref[kThrottleDelta] + kThrottleEquil, 0.0, 1.0);
  u.elevator_deg = clamp_value(el + kElevatorEquil_deg, -kElevatorMax_deg, kElevatorMax_deg);
  u.aileron_deg = clamp_value(ail, -kAileronMax_deg, kAileronMax_deg);
  u.rudder_deg = clamp_value(rdr, -kRudderMax_deg, kRudderMax_deg);
  return u;
}

struct ClosedLoopOutputs {
  double xdot[kNumStates];
  SurfaceCommands surfaces;  // after saturation
  double nz_g;               // normal load factor at the accelerometer
  double ps_radps;           // stability-axis roll rate (uses the alpha perturbation, as AeroBench)
  double ny_r;               // Ny + r, mixed units
  double ny_g;
};

// Full 16-state derivative of plant + inner loop (AeroBench controlled_f16, non-v2 integrators).
template <AeroModel MODEL>
F16_INLINE ClosedLoopOutputs closed_loop_derivative(const double* x, const double* u_ref) {
  ClosedLoopOutputs out;
  out.surfaces = inner_loop_commands(x, u_ref);
  const PlantOutputs plant = plant_derivative<MODEL>(x, out.surfaces);
  #pragma GCC unroll 16
  for (int i = 0; i < kNumPlantStates; ++i) out.xdot[i] = plant.xdot[i];
  double s_da, c_da;
  vmath::sincos(x[kAlpha] - lqr::kAlphaEquil_rad, &s_da, &c_da);
  out.nz_g = plant.nz_g;
  out.ny_g = plant.ny_g;
  out.ps_radps = x[kP] * c_da + x[kR] * s_da;
  out.ny_r = plant.ny_g + x[kR];
  out.xdot[kIntNz] = out.nz_g - u_ref[kNzRef];
  out.xdot[kIntPs] = out.ps_radps - u_ref[kPsRef];
  out.xdot[kIntNyR] = out.ny_r - u_ref[kNyRRef];
  return out;
}

}  // namespace f16race::dynamics
