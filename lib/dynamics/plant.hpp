#pragma once
// The 13-state F-16 plant derivative: AeroBench lowlevel/subf16_model.py (Stevens & Lewis,
// App. A), with adjust_cy=True. Inline and branch-free so the batched integrator vectorises it.
// Traps reproduced on purpose (see tests/data/README.md): angles go to degrees with 57.29578,
// not 180/pi; the Stevens damping table is added for BOTH aero models; the normal acceleration
// is measured 15 ft ahead of the c.g.
#include "dynamics/engine.hpp"
#include "dynamics/morelli_aero.hpp"
#include "dynamics/physical_constants.hpp"
#include "dynamics/stevens_aero.hpp"
#include "dynamics/state.hpp"
#include "dynamics/vector_math.hpp"

namespace f16race::dynamics {

// Surface commands as subf16_model takes them: throttle 0..1, deflections in degrees.
struct SurfaceCommands {
  double throttle;
  double elevator_deg;
  double aileron_deg;
  double rudder_deg;
};

struct PlantOutputs {
  double xdot[kNumPlantStates];
  double nz_g;          // normal load factor at the accelerometer, zeroed at 1 g, + pulling up
  double ny_g;          // lateral load factor at the accelerometer
  double az_out_ftps2;  // az_cg - 15 * qdot
  double ay_out_ftps2;  // ay_cg + 15 * rdot
};

// Airframe constants (Stevens & Lewis App. A / AeroBench subf16_model.py).
namespace airframe {
inline constexpr double kWingArea_ft2 = 300.0;
inline constexpr double kSpan_ft = 30.0;
inline constexpr double kChord_ft = 11.32;
inline constexpr double kInvMass = 1.57e-3;  // 1/m [1/slug]
inline constexpr double kXcgRef = 0.35;
inline constexpr double kXcg = 0.35;
inline constexpr double kEngineMomentum = 160.0;  // he [slug ft^2/s]
inline constexpr double kC1 = -0.770, kC2 = 0.02755, kC3 = 1.055e-4, kC4 = 1.642e-6, kC5 = 0.9604;
inline constexpr double kC6 = 1.759e-2, kC7 = 1.792e-5, kC8 = -0.7336, kC9 = 1.587e-5;
inline constexpr double kRadToDeg = 57.29578;  // AeroBench's constant, deliberately not 180/pi
inline constexpr double kAccelArm_ft = 15.0;   // accelerometer ahead of the c.g. (pilot station)
}  // namespace airframe

// x: the 13 plant states in AeroBench order. MODEL is a template parameter so that each batched
// kernel contains one aero model only.
template <AeroModel MODEL>
F16_INLINE PlantOutputs plant_derivative(const double* x, const SurfaceCommands& u) {
  using namespace airframe;
  const double vt = x[kVt];
  const double alpha_deg = x[kAlpha] * kRadToDeg;
  const double beta_deg = x[kBeta] * kRadToDeg;
  const double p = x[kP], q = x[kQ], r = x[kR];
  const double alt = x[kAlt];
  const double power = x[kPow];

  const AirData air = air_data(vt, alt);
  const double cpow = throttle_gearing(u.throttle);
  PlantOutputs out;
  out.xdot[kPow] = power_derivative(power, cpow);
  const double thrust = engine_thrust(power, alt, air.mach);

  double cxt, cyt, czt, clt, cmt, cnt;
  if constexpr (MODEL == AeroModel::kStevens) {
    const double dail = u.aileron_deg / 20.0;
    const double drdr = u.rudder_deg / 30.0;
    cxt = stevens_cx(alpha_deg, u.elevator_deg);
    cyt = stevens_cy(beta_deg, u.aileron_deg, u.rudder_deg);
    czt = stevens_cz(alpha_deg, beta_deg, u.elevator_deg);
    clt = stevens_cl(alpha_deg, beta_deg) + stevens_dlda(alpha_deg, beta_deg) * dail +
          stevens_dldr(alpha_deg, beta_deg) * drdr;
    cmt = stevens_cm(alpha_deg, u.elevator_deg);
    cnt = stevens_cn(alpha_deg, beta_deg) + stevens_dnda(alpha_deg, beta_deg) * dail +
          stevens_dndr(alpha_deg, beta_deg) * drdr;
  } else {
    const AeroCoefficients c = morelli_coefficients(
        alpha_deg * kPi / 180.0, beta_deg * kPi / 180.0, u.elevator_deg * kPi / 180.0,
        u.aileron_deg * kPi / 180.0, u.rudder_deg * kPi / 180.0, p, q, r, kChord_ft, kSpan_ft, vt, kXcg, kXcgRef);
    cxt = c.cx;
    cyt = c.cy;
    czt = c.cz;
    clt = c.cl;
    cmt = c.cm;
    cnt = c.cn;
  }

  // Stevens table damping, added on top of either model as AeroBench does.
  const double tvt = 0.5 / vt;
  const double b2v = kSpan_ft * tvt;
  const double cq = kChord_ft * q * tvt;
  const Damping d = stevens_damping(alpha_deg);
  cxt = cxt + cq * d.d[0];
  cyt = cyt + b2v * (d.d[1] * r + d.d[2] * p);
  czt = czt + cq * d.d[3];
  clt = clt + b2v * (d.d[4] * r + d.d[5] * p);
  cmt = cmt + cq * d.d[6] + czt * (kXcgRef - kXcg);
  cnt = cnt + b2v * (d.d[7] * r + d.d[8] * p) - cyt * (kXcgRef - kXcg) * kChord_ft / kSpan_ft;

  double sa, ca, sb, cb, sth, cth, sph, cph, sps, cps;
  vmath::sincos(x[kAlpha], &sa, &ca);
  vmath::sincos(x[kBeta], &sb, &cb);
  vmath::sincos(x[kTheta], &sth, &cth);
  vmath::sincos(x[kPhi], &sph, &cph);
  vmath::sincos(x[kPsi], &sps, &cps);

  const double uu = vt * ca * cb;
  const double vv = vt * sb;
  const double ww = vt * sa * cb;
  const double qs = air.qbar_psf * kWingArea_ft2;
  const double qsb = qs * kSpan_ft;
  const double rmqs = kInvMass * qs;
  const double gcth = kG * cth;
  const double qsph = q * sph;
  const double ay = rmqs * cyt;
  const double az = rmqs * czt;

  // Force equations in body axes.
  const double udot = r * vv - q * ww - kG * sth + kInvMass * (qs * cxt + thrust);
  const double vdot = p * ww - r * uu + gcth * sph + ay;
  const double wdot = q * uu - p * vv + gcth * cph + az;
  const double dum = uu * uu + ww * ww;
  out.xdot[kVt] = (uu * udot + vv * vdot + ww * wdot) / vt;
  out.xdot[kAlpha] = (uu * wdot - ww * udot) / dum;
  out.xdot[kBeta] = (vt * vdot - vv * out.xdot[kVt]) * cb / dum;

  // Euler-angle kinematics (singular at theta = +-90 deg; the batch flags aircraft before that).
  out.xdot[kPhi] = p + (sth / cth) * (qsph + r * cph);
  out.xdot[kTheta] = q * cph - r * sph;
  out.xdot[kPsi] = (qsph + r * cph) / cth;

  // Moment equations.
  out.xdot[kP] = (kC2 * p + kC1 * r + kC4 * kEngineMomentum) * q + qsb * (kC3 * clt + kC4 * cnt);
  out.xdot[kQ] = (kC5 * p - kC7 * kEngineMomentum) * r + kC6 * (r * r - p * p) + qs * kChord_ft * kC7 * cmt;
  out.xdot[kR] = (kC8 * p - kC2 * r + kC9 * kEngineMomentum) * q + qsb * (kC4 * clt + kC9 * cnt);

  // Navigation: body velocity rotated into north-east-up.
  const double t1 = sph * cps, t2 = cph * sth, t3 = sph * sps;
  const double s1 = cth * cps, s2 = cth * sps;
  const double s3 = t1 * sth - cph * sps, s4 = t3 * sth + cph * cps;
  const double s5 = sph * cth, s6 = t2 * cps + t3, s7 = t2 * sps - t1, s8 = cph * cth;
  out.xdot[kPn] = uu * s1 + vv * s3 + ww * s6;
  out.xdot[kPe] = uu * s2 + vv * s4 + ww * s7;
  out.xdot[kAlt] = uu * sth - vv * s5 - ww * s8;

  out.az_out_ftps2 = az - kAccelArm_ft * out.xdot[kQ];
  out.ay_out_ftps2 = ay + kAccelArm_ft * out.xdot[kR];
  out.nz_g = (-out.az_out_ftps2 / kG) - 1.0;
  out.ny_g = out.ay_out_ftps2 / kG;
  return out;
}

}  // namespace f16race::dynamics
