#include "dynamics/model_probe.hpp"

#include "dynamics/inner_loop.hpp"

namespace f16race::dynamics {

std::vector<NamedValue> probe_plant(AeroModel model, const double* x13, const SurfaceCommands& u) {
  using namespace airframe;
  const PlantOutputs out = model == AeroModel::kMorelli ? plant_derivative<AeroModel::kMorelli>(x13, u)
                                                        : plant_derivative<AeroModel::kStevens>(x13, u);
  std::vector<NamedValue> v;
  for (int i = 0; i < kNumPlantStates; ++i) v.push_back({kStateDerivativeNames[i], out.xdot[i]});
  v.push_back({"Nz_g", out.nz_g});
  v.push_back({"Ny_g", out.ny_g});
  v.push_back({"az_out_ftps2", out.az_out_ftps2});
  v.push_back({"ay_out_ftps2", out.ay_out_ftps2});
  const AirData air = air_data(x13[kVt], x13[kAlt]);
  v.push_back({"mach", air.mach});
  v.push_back({"qbar_psf", air.qbar_psf});
  v.push_back({"cpow_tgear_pct", throttle_gearing(u.throttle)});
  v.push_back({"thrust_lbf", engine_thrust(x13[kPow], x13[kAlt], air.mach)});
  const double alpha_deg = x13[kAlpha] * kRadToDeg;
  const double beta_deg = x13[kBeta] * kRadToDeg;
  v.push_back({"alpha_deg_internal", alpha_deg});
  v.push_back({"beta_deg_internal", beta_deg});
  if (model == AeroModel::kStevens) {
    v.push_back({"cx", stevens_cx(alpha_deg, u.elevator_deg)});
    v.push_back({"cy", stevens_cy(beta_deg, u.aileron_deg, u.rudder_deg)});
    v.push_back({"cz", stevens_cz(alpha_deg, beta_deg, u.elevator_deg)});
    v.push_back({"cl", stevens_cl(alpha_deg, beta_deg)});
    v.push_back({"dlda", stevens_dlda(alpha_deg, beta_deg)});
    v.push_back({"dldr", stevens_dldr(alpha_deg, beta_deg)});
    v.push_back({"cm", stevens_cm(alpha_deg, u.elevator_deg)});
    v.push_back({"cn", stevens_cn(alpha_deg, beta_deg)});
    v.push_back({"dnda", stevens_dnda(alpha_deg, beta_deg)});
    v.push_back({"dndr", stevens_dndr(alpha_deg, beta_deg)});
  } else {
    const AeroCoefficients c = morelli_coefficients(
        alpha_deg * kPi / 180.0, beta_deg * kPi / 180.0, u.elevator_deg * kPi / 180.0, u.aileron_deg * kPi / 180.0,
        u.rudder_deg * kPi / 180.0, x13[kP], x13[kQ], x13[kR], kChord_ft, kSpan_ft, x13[kVt], kXcg, kXcgRef);
    v.push_back({"morelli_Cx", c.cx});
    v.push_back({"morelli_Cy", c.cy});
    v.push_back({"morelli_Cz", c.cz});
    v.push_back({"morelli_Cl", c.cl});
    v.push_back({"morelli_Cm", c.cm});
    v.push_back({"morelli_Cn", c.cn});
  }
  const Damping d = stevens_damping(alpha_deg);
  for (int i = 0; i < 9; ++i) v.push_back({"dampp_d" + std::to_string(i), d.d[i]});
  return v;
}

std::vector<NamedValue> probe_closed_loop(AeroModel model, const StateVector& x, const RefVector& u_ref) {
  const ClosedLoopOutputs o = model == AeroModel::kMorelli
                                  ? closed_loop_derivative<AeroModel::kMorelli>(x.data(), u_ref.data())
                                  : closed_loop_derivative<AeroModel::kStevens>(x.data(), u_ref.data());
  std::vector<NamedValue> v;
  v.push_back({kSurfaceNames[0], o.surfaces.throttle});
  v.push_back({kSurfaceNames[1], o.surfaces.elevator_deg});
  v.push_back({kSurfaceNames[2], o.surfaces.aileron_deg});
  v.push_back({kSurfaceNames[3], o.surfaces.rudder_deg});
  for (int i = 0; i < kNumStates; ++i) v.push_back({kStateDerivativeNames[i], o.xdot[i]});
  v.push_back({"Nz_g", o.nz_g});
  v.push_back({"ps_radps", o.ps_radps});
  v.push_back({"Ny_r_mixed", o.ny_r});
  return v;
}

}  // namespace f16race::dynamics
