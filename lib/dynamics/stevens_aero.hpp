#pragma once
// Stevens & Lewis table look-ups with AeroBench's interpolation rule (lowlevel/cx.py etc.):
// the breakpoint index is truncated toward zero and clamped, and the neighbour is taken on the
// side of the remainder, so values past the table ends are extrapolated linearly from the last
// two breakpoints. Angles are in degrees, as AeroBench passes them (rad * 57.29578).
#include "dynamics/stevens_tables.hpp"
#include "dynamics/vector_math.hpp"

namespace f16race::dynamics {

// One table axis resolved: row/column `lo`, its neighbour `hi` and the weight |remainder|.
struct TableAxis {
  int lo;
  int hi;
  double w;
};

// Axis at breakpoints spaced 1/scale apart with clamped integer index in [lo_clamp, hi_clamp];
// `offset` maps the integer index to the array index. NaN input lands on lo_clamp, never
// outside the table, so a diverged aircraft cannot read out of bounds.
F16_INLINE TableAxis table_axis(double value, double scale, double lo_clamp, double hi_clamp, int offset) {
  const double s = scale * value;
  double k = std::trunc(s);
  k = (k > lo_clamp) ? k : lo_clamp;
  k = (k < hi_clamp) ? k : hi_clamp;
  const double d = s - k;
  const double l = k + ((d > 0.0) ? 1.0 : ((d < 0.0) ? -1.0 : 0.0));
  return {static_cast<int>(k) + offset, static_cast<int>(l) + offset, std::fabs(d)};
}

// Alpha axis shared by every table: -10..45 deg every 5 deg.
F16_INLINE TableAxis alpha_axis(double alpha_deg) { return table_axis(alpha_deg, 0.2, -1.0, 8.0, 2); }

// Bilinear look-up in table[row * 12 + alpha] with AeroBench's arithmetic order. The table is
// taken by array reference so that, once inlined, GCC sees a gather from a named global.
template <int N>
F16_INLINE double lookup2(const double (&table)[N], const TableAxis& a, const TableAxis& r) {
  const double t = table[r.lo * 12 + a.lo];
  const double u = table[r.hi * 12 + a.lo];
  const double v = t + a.w * (table[r.lo * 12 + a.hi] - t);
  const double w = u + a.w * (table[r.hi * 12 + a.hi] - u);
  return v + (w - v) * r.w;
}

F16_INLINE double sign_of(double x) { return (x > 0.0) ? 1.0 : ((x < 0.0) ? -1.0 : 0.0); }

// Elevator axis: -24..24 deg every 12 deg.
F16_INLINE TableAxis elevator_axis(double el_deg) { return table_axis(el_deg, 1.0 / 12.0, -1.0, 1.0, 2); }
// |beta| axis of cl and cn: 0..30 deg every 5 deg (AeroBench forces the index into 1..5).
F16_INLINE TableAxis abs_beta_axis(double beta_deg) { return table_axis(std::fabs(beta_deg), 0.2, 1.0, 5.0, 0); }
// Signed beta axis of the control-derivative tables: -30..30 deg every 10 deg.
F16_INLINE TableAxis beta_axis(double beta_deg) { return table_axis(beta_deg, 0.1, -2.0, 2.0, 3); }

F16_INLINE double stevens_cx(double alpha_deg, double el_deg) {
  return lookup2(tables::kCxTable, alpha_axis(alpha_deg), elevator_axis(el_deg));
}

F16_INLINE double stevens_cy(double beta_deg, double ail_deg, double rdr_deg) {
  return -0.02 * beta_deg + 0.021 * (ail_deg / 20.0) + 0.086 * (rdr_deg / 30.0);
}

F16_INLINE double stevens_cz(double alpha_deg, double beta_deg, double el_deg) {
  const TableAxis a = alpha_axis(alpha_deg);
  const double t = tables::kCzTable[a.lo];
  const double s = t + a.w * (tables::kCzTable[a.hi] - t);
  const double b = beta_deg / 57.3;
  return s * (1.0 - b * b) - 0.19 * (el_deg / 25.0);
}

F16_INLINE double stevens_cl(double alpha_deg, double beta_deg) {
  return lookup2(tables::kClTable, alpha_axis(alpha_deg), abs_beta_axis(beta_deg)) * sign_of(beta_deg);
}

F16_INLINE double stevens_cm(double alpha_deg, double el_deg) {
  return lookup2(tables::kCmTable, alpha_axis(alpha_deg), elevator_axis(el_deg));
}

F16_INLINE double stevens_cn(double alpha_deg, double beta_deg) {
  return lookup2(tables::kCnTable, alpha_axis(alpha_deg), abs_beta_axis(beta_deg)) * sign_of(beta_deg);
}

F16_INLINE double stevens_dlda(double alpha_deg, double beta_deg) {
  return lookup2(tables::kDldaTable, alpha_axis(alpha_deg), beta_axis(beta_deg));
}
F16_INLINE double stevens_dldr(double alpha_deg, double beta_deg) {
  return lookup2(tables::kDldrTable, alpha_axis(alpha_deg), beta_axis(beta_deg));
}
F16_INLINE double stevens_dnda(double alpha_deg, double beta_deg) {
  return lookup2(tables::kDndaTable, alpha_axis(alpha_deg), beta_axis(beta_deg));
}
F16_INLINE double stevens_dndr(double alpha_deg, double beta_deg) {
  return lookup2(tables::kDndrTable, alpha_axis(alpha_deg), beta_axis(beta_deg));
}

// The nine damping derivatives (CXq, CYr, CYp, CZq, Clr, Clp, Cmq, Cnr, Cnp) at alpha.
struct Damping {
  double d[9];
};

F16_INLINE Damping stevens_damping(double alpha_deg) {
  const TableAxis a = alpha_axis(alpha_deg);
  Damping out;
  #pragma GCC unroll 16
  for (int i = 0; i < 9; ++i) {
    const double t = tables::kDampTable[i * 12 + a.lo];
    out.d[i] = t + a.w * (tables::kDampTable[i * 12 + a.hi] - t);
  }
  return out;
}

}  // namespace f16race::dynamics
