#include "dynamics/trim.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "dynamics/inner_loop.hpp"

namespace f16race::dynamics {
namespace {

struct Residual {
  double r[3];
};

Residual level_residual(AeroModel model, const TrimRequest& req, const double z[3]) {
  double x[kNumPlantStates] = {};
  x[kVt] = req.vt_ftps;
  x[kAlpha] = z[0];
  x[kTheta] = z[0];
  x[kPsi] = req.psi_rad;
  x[kAlt] = req.alt_ft;
  x[kPow] = throttle_gearing(z[2]);
  const SurfaceCommands u{z[2], z[1], 0.0, 0.0};
  const PlantOutputs out = model == AeroModel::kMorelli ? plant_derivative<AeroModel::kMorelli>(x, u)
                                                        : plant_derivative<AeroModel::kStevens>(x, u);
  return {{out.xdot[kVt], out.xdot[kAlpha], out.xdot[kQ]}};
}

bool solve3(double a[3][3], const double b[3], double x[3]) {
  // Cramer's rule: the 3x3 Jacobian is tiny and well scaled by the Newton step below.
  const double det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
                     a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
                     a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
  if (!(std::fabs(det) > 0.0) || !std::isfinite(det)) return false;
  for (int c = 0; c < 3; ++c) {
    double m[3][3];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) m[i][j] = (j == c) ? b[i] : a[i][j];
    x[c] = (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
            m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])) / det;
  }
  return true;
}

double max_abs(const Residual& r) {
  return std::fmax(std::fabs(r.r[0]), std::fmax(std::fabs(r.r[1]), std::fabs(r.r[2])));
}

}  // namespace

TrimResult trim_level_flight(const TrimRequest& req) {
  auto fail = [&](const std::string& why) {
    std::ostringstream msg;
    msg << "trim at vt=" << req.vt_ftps << " ft/s, alt=" << req.alt_ft << " ft (" << aero_model_name(req.model)
        << "): " << why << "; choose a speed/altitude the F-16 can hold level (e.g. 400-900 ft/s below 40000 ft)";
    throw TrimError(msg.str());
  };
  if (!(req.vt_ftps > 0.0) || !std::isfinite(req.alt_ft)) fail("invalid request");

  double z[3] = {0.05, -1.0, 0.2};  // alpha [rad], elevator [deg], throttle [-]
  Residual r = level_residual(req.model, req, z);
  for (int iter = 0; iter < 60 && max_abs(r) > 1e-13; ++iter) {
    const double h[3] = {1e-7, 1e-6, 1e-7};
    double jac[3][3];
    for (int c = 0; c < 3; ++c) {
      double zp[3] = {z[0], z[1], z[2]}, zm[3] = {z[0], z[1], z[2]};
      zp[c] += h[c];
      zm[c] -= h[c];
      const Residual rp = level_residual(req.model, req, zp);
      const Residual rm = level_residual(req.model, req, zm);
      for (int i = 0; i < 3; ++i) jac[i][c] = (rp.r[i] - rm.r[i]) / (2.0 * h[c]);
    }
    double step[3];
    if (!solve3(jac, r.r, step)) fail("singular Jacobian");
    // Damped Newton: halve the step until the residual drops, so a poor start cannot diverge.
    double lambda = 1.0;
    Residual rn{};
    double zn[3];
    for (int k = 0; k < 30; ++k, lambda *= 0.5) {
      for (int i = 0; i < 3; ++i) zn[i] = z[i] - lambda * step[i];
      rn = level_residual(req.model, req, zn);
      if (max_abs(rn) < max_abs(r)) break;
    }
    for (int i = 0; i < 3; ++i) z[i] = zn[i];
    r = rn;
  }
  const double residual = max_abs(r);
  if (!(residual < 1e-9)) fail("Newton did not converge (residual " + std::to_string(residual) + ")");
  if (z[2] < 0.0 || z[2] > 1.0) fail("needs throttle " + std::to_string(z[2]) + " outside [0, 1]");
  if (std::fabs(z[1]) > lqr::kElevatorMax_deg) fail("needs elevator beyond +-25 deg");

  TrimResult t;
  t.alpha_rad = z[0];
  t.elevator_deg = z[1];
  t.throttle = z[2];
  t.residual = residual;
  t.x0.fill(0.0);
  t.x0[kVt] = req.vt_ftps;
  t.x0[kAlpha] = z[0];
  t.x0[kTheta] = z[0];
  t.x0[kPsi] = req.psi_rad;
  t.x0[kAlt] = req.alt_ft;
  t.x0[kPow] = throttle_gearing(z[2]);
  // Preload int_e_Nz so the LQR's elevator equals the trim elevator at t = 0.
  t.x0[kIntNz] = (lqr::kElevatorEquil_deg - z[1] - lqr::kLong[0] * (z[0] - lqr::kAlphaEquil_rad)) / lqr::kLong[2];
  // AeroBench's Nz reads cos(theta) - 1 in level flight, so that is the reference that holds it.
  t.u_ref = {std::cos(z[0]) - 1.0, 0.0, 0.0, z[2] - lqr::kThrottleEquil};
  return t;
}

}  // namespace f16race::dynamics
