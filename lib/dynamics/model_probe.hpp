#pragma once
// Every quantity AeroBench exposes at a single point, named as in the reference CSVs
// (tests/data/deriv_*.csv). Lets a user, the `simulate --derivatives` tool and the tests check
// the model anywhere without integrating.
#include <string>
#include <vector>

#include "dynamics/plant.hpp"
#include "dynamics/state.hpp"

namespace f16race::dynamics {

struct NamedValue {
  std::string name;
  double value;
};

// Plant point (AeroBench subf16_model and its helpers): 13 xdot, Nz_g, Ny_g, az_out_ftps2,
// ay_out_ftps2, mach, qbar_psf, cpow_tgear_pct, thrust_lbf, alpha/beta_deg_internal, the raw
// aero coefficients of the chosen model (Stevens: cx..dndr; Morelli: morelli_Cx..Cn), dampp_d0..8.
std::vector<NamedValue> probe_plant(AeroModel model, const double* x13, const SurfaceCommands& u);

// Closed-loop point (AeroBench controlled_f16): surface commands, 16 xdot, Nz_g, ps_radps,
// Ny_r_mixed.
std::vector<NamedValue> probe_closed_loop(AeroModel model, const StateVector& x, const RefVector& u_ref);

}  // namespace f16race::dynamics
