#pragma once
// Morelli's global polynomial F-16 aerodynamic model (E. A. Morelli, "Global Nonlinear
// Aerodynamic Modeling Using Multivariate Orthogonal Functions", J. Aircraft 32(2), 1995), with
// the coefficients as AeroBench transcribes them (lowlevel/morellif16.py, commit afa9f0a).
// Powers are written as products: pow() would stop vectorisation and costs twice the time.
#include "dynamics/vector_math.hpp"

namespace f16race::dynamics {

struct AeroCoefficients {
  double cx, cy, cz, cl, cm, cn;
};

// Angles and surface deflections in rad, body rates in rad/s, airspeed in ft/s. Includes
// Morelli's own rate derivatives and the c.g. correction (xcg - xcgref).
F16_INLINE AeroCoefficients morelli_coefficients(double alpha, double beta, double de, double da, double dr,
                                                 double p, double q, double r, double cbar, double b,
                                                 double vt, double xcg, double xcgref) {
  const double phat = p * b / (2.0 * vt);
  const double qhat = q * cbar / (2.0 * vt);
  const double rhat = r * b / (2.0 * vt);

  const double a1 = alpha, a2 = alpha * alpha, a3 = a2 * alpha, a4 = a2 * a2, a5 = a4 * alpha;
  const double b1 = beta, b2 = beta * beta, b3 = b2 * beta;
  const double de2 = de * de, de3 = de2 * de;

  const double cx0 = -1.943367e-2 + 2.136104e-1 * a1 + -2.903457e-1 * de2 + -3.348641e-3 * de +
                     -2.060504e-1 * a1 * de + 6.988016e-1 * a2 + -9.035381e-1 * a3;
  const double cxq = 4.833383e-1 + 8.644627 * a1 + 1.131098e1 * a2 + -7.422961e1 * a3 + 6.075776e1 * a4;
  const double cy0 = -1.145916 * b1 + 6.016057e-2 * da + 1.642479e-1 * dr;
  const double cyp = -1.006733e-1 + 8.679799e-1 * a1 + 4.260586 * a2 + -6.923267 * a3;
  const double cyr = 8.071648e-1 + 1.189633e-1 * a1 + 4.177702 * a2 + -9.162236 * a3;
  const double cz0 = (-1.378278e-1 + -4.211369 * a1 + 4.775187 * a2 + -1.026225e1 * a3 + 8.399763 * a4) * (1.0 - b2) +
                     -4.354000e-1 * de;
  const double czq = -3.054956e1 + -4.132305e1 * a1 + 3.292788e2 * a2 + -6.848038e2 * a3 + 4.080244e2 * a4;
  const double cl0 = -1.05853e-1 * b1 + -5.776677e-1 * a1 * b1 + -1.672435e-2 * a2 * b1 + 1.357256e-1 * b2 +
                     2.172952e-1 * a1 * b2 + 3.464156 * a3 * b1 + -2.835451 * a4 * b1 + -1.098104 * a2 * b2;
  const double clp = -4.126806e-1 + -1.189974e-1 * a1 + 1.247721 * a2 + -7.391132e-1 * a3;
  const double clr = 6.250437e-2 + 6.067723e-1 * a1 + -1.101964 * a2 + 9.100087 * a3 + -1.192672e1 * a4;
  const double clda = -1.463144e-1 + -4.07391e-2 * a1 + 3.253159e-2 * b1 + 4.851209e-1 * a2 + 2.978850e-1 * a1 * b1 +
                      -3.746393e-1 * a2 * b1 + -3.213068e-1 * a3;
  const double cldr = 2.635729e-2 + -2.192910e-2 * a1 + -3.152901e-3 * b1 + -5.817803e-2 * a1 * b1 +
                      4.516159e-1 * a2 * b1 + -4.928702e-1 * a3 * b1 + -1.579864e-2 * b2;
  const double cm0 = -2.029370e-2 + 4.660702e-2 * a1 + -6.012308e-1 * de + -8.062977e-2 * a1 * de + 8.320429e-2 * de2 +
                     5.018538e-1 * a2 * de + 6.378864e-1 * de3 + 4.226356e-1 * a1 * de2;
  const double cmq = -5.19153 + -3.554716 * a1 + -3.598636e1 * a2 + 2.247355e2 * a3 + -4.120991e2 * a4 + 2.411750e2 * a5;
  const double cn0 = 2.993363e-1 * b1 + 6.594004e-2 * a1 * b1 + -2.003125e-1 * b2 + -6.233977e-2 * a1 * b2 +
                     -2.107885 * a2 * b1 + 2.141420 * a2 * b2 + 8.476901e-1 * a3 * b1;
  const double cnp = 2.677652e-2 + -3.298246e-1 * a1 + 1.926178e-1 * a2 + 4.013325 * a3 + -4.404302 * a4;
  const double cnr = -3.698756e-1 + -1.167551e-1 * a1 + -7.641297e-1 * a2;
  const double cnda = -3.348717e-2 + 4.276655e-2 * a1 + 6.573646e-3 * b1 + 3.535831e-1 * a1 * b1 +
                      -1.373308 * a2 * b1 + 1.237582 * a3 * b1 + 2.302543e-1 * a2 + -2.512876e-1 * a3 +
                      1.588105e-1 * b3 + -5.199526e-1 * a1 * b3;
  const double cndr = -8.115894e-2 + -1.156580e-2 * a1 + 2.514167e-2 * b1 + 2.038748e-1 * a1 * b1 +
                      -3.337476e-1 * a2 * b1 + 1.004297e-1 * a2;

  AeroCoefficients c;
  c.cx = cx0 + cxq * qhat;
  c.cy = cy0 + cyp * phat + cyr * rhat;
  c.cz = cz0 + czq * qhat;
  c.cl = cl0 + clp * phat + clr * rhat + clda * da + cldr * dr;
  c.cm = cm0 + cmq * qhat + c.cz * (xcgref - xcg);
  c.cn = cn0 + cnp * phat + cnr * rhat + cnda * da + cndr * dr - c.cy * (xcgref - xcg) * (cbar / b);
  return c;
}

}  // namespace f16race::dynamics
