#pragma once
// The 16-element AeroBench F-16 state (13 plant states + 3 inner-loop integrators), its order,
// names and units. Order and units follow AeroBench (stanleybak/AeroBenchVVPython) exactly so
// that reference trajectories can be compared column by column.
#include <array>
#include <cstddef>

namespace f16race::dynamics {

inline constexpr int kNumPlantStates = 13;
inline constexpr int kNumStates = 16;
inline constexpr int kNumRefs = 4;

// Index of each state in AeroBench's 16-vector.
enum StateIndex : int {
  kVt = 0,      // true airspeed [ft/s]
  kAlpha = 1,   // angle of attack [rad]
  kBeta = 2,    // sideslip [rad]
  kPhi = 3,     // roll angle [rad]
  kTheta = 4,   // pitch angle [rad]
  kPsi = 5,     // heading from north [rad]
  kP = 6,       // body roll rate [rad/s]
  kQ = 7,       // body pitch rate [rad/s]
  kR = 8,       // body yaw rate [rad/s]
  kPn = 9,      // north position [ft]
  kPe = 10,     // east position [ft]
  kAlt = 11,    // altitude, positive up [ft]
  kPow = 12,    // engine power-lag state [%], 0..100, 50 = military power
  kIntNz = 13,  // integral of (Nz - Nz_ref) [g*s]
  kIntPs = 14,  // integral of (ps - ps_ref) [rad]
  kIntNyR = 15  // integral of (Ny + r - Ny_r_ref) [(g + rad/s)*s], mixed units as in AeroBench
};

// Index of each outer-loop reference (AeroBench's u_ref).
enum RefIndex : int {
  kNzRef = 0,         // normal-acceleration reference [g]
  kPsRef = 1,         // stability-axis roll-rate reference [rad/s]
  kNyRRef = 2,        // (side acceleration + yaw rate) reference [g + rad/s]
  kThrottleDelta = 3  // throttle offset added to the trim throttle 0.1395 [-]
};

// Column names used by the reference CSVs (../shared/reference/aerobench) and our own outputs.
inline constexpr std::array<const char*, kNumStates> kStateNames = {
    "vt_ftps", "alpha_rad", "beta_rad", "phi_rad",  "theta_rad", "psi_rad",
    "p_radps", "q_radps",   "r_radps",  "pn_ft",    "pe_ft",     "alt_ft",
    "pow_pct", "int_e_Nz_gs", "int_e_ps_rad", "int_e_Ny_r_mixed_s"};

inline constexpr std::array<const char*, kNumStates> kStateDerivativeNames = {
    "dvt_ftps2",   "dalpha_radps", "dbeta_radps", "dphi_radps",  "dtheta_radps", "dpsi_radps",
    "dp_radps2",   "dq_radps2",    "dr_radps2",   "dpn_ftps",    "dpe_ftps",     "dalt_ftps",
    "dpow_pctps",  "dint_e_Nz_g",  "dint_e_ps_radps", "dint_e_Ny_r_mixed"};

inline constexpr std::array<const char*, kNumRefs> kRefNames = {
    "Nz_ref_g", "ps_ref_radps", "Ny_r_ref_mixed", "throttle_ref_delta"};

inline constexpr std::array<const char*, 4> kSurfaceNames = {
    "throttle_cmd", "elevator_cmd_deg", "aileron_cmd_deg", "rudder_cmd_deg"};

using StateVector = std::array<double, kNumStates>;
using RefVector = std::array<double, kNumRefs>;

// Which aerodynamic coefficient model the plant uses.
enum class AeroModel { kMorelli, kStevens };

// "morelli" / "stevens"; returns false for anything else.
bool parse_aero_model(const char* text, AeroModel* out);
const char* aero_model_name(AeroModel model);

}  // namespace f16race::dynamics
