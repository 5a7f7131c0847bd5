#include "dynamics/f16_batch.hpp"

#include <cstdlib>
#include <cstring>
#include <istream>
#include <ostream>
#include <new>
#include <stdexcept>
#include <string>

#include "dynamics/autopilot_laws.hpp"
#include "dynamics/inner_loop.hpp"

namespace f16race::dynamics {

bool parse_aero_model(const char* text, AeroModel* out) {
  if (std::strcmp(text, "morelli") == 0) { *out = AeroModel::kMorelli; return true; }
  if (std::strcmp(text, "stevens") == 0) { *out = AeroModel::kStevens; return true; }
  return false;
}

const char* aero_model_name(AeroModel model) { return model == AeroModel::kMorelli ? "morelli" : "stevens"; }

bool parse_integrator(const char* text, Integrator* out) {
  if (std::strcmp(text, "rk4") == 0) { *out = Integrator::kRk4; return true; }
  if (std::strcmp(text, "euler") == 0) { *out = Integrator::kEuler; return true; }
  return false;
}

const char* integrator_name(Integrator integrator) { return integrator == Integrator::kRk4 ? "rk4" : "euler"; }

const char* stage_law_name(StageLaw law) {
  switch (law) {
    case StageLaw::kHeld: return "held";
    case StageLaw::kGcas: return "gcas";
    case StageLaw::kWaypoint: return "waypoint";
  }
  return "unknown";
}

const char* status_name(std::int32_t status) {
  switch (status) {
    case kStatusOk: return "ok";
    case kStatusNonFinite: return "non_finite";
    case kStatusAlpha: return "alpha_limit";
    case kStatusBeta: return "beta_limit";
    case kStatusTheta: return "theta_limit";
    case kStatusSpeed: return "speed_limit";
    case kStatusAltitude: return "altitude_limit";
    case kStatusPadding: return "padding";
    case kStatusRetired: return "retired";
    default: return "unknown";
  }
}

void F16Batch::FreeDeleter::operator()(void* p) const { std::free(p); }

// The AVX-512 copies of the kernels, for a build whose own target lacks AVX-512 (the reproducible
// x86-64-v3 one): the same inline code compiled a second time for these extensions, chosen at run
// time. The callees are always_inline and carry no target of their own, so they are compiled
// inside each copy (a subset of its extensions may be inlined); no out-of-line function is shared.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(__AVX512F__)
#define F16_WIDE_KERNELS 1
#define F16_WIDE_TARGET __attribute__((target("avx512f,avx512bw,avx512cd,avx512dq,avx512vl,prefer-vector-width=512")))
#else
#define F16_WIDE_KERNELS 0
#endif

bool wide_kernels_available() {
#if F16_WIDE_KERNELS
  static const bool available = __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
                                __builtin_cpu_supports("avx512cd") && __builtin_cpu_supports("avx512dq") &&
                                __builtin_cpu_supports("avx512vl");
  return available;
#else
  return false;
#endif
}

namespace {

template <typename T>
T* aligned_array(std::size_t count) {
  std::size_t bytes = count * sizeof(T);
  bytes = (bytes + 63) / 64 * 64;  // aligned_alloc wants a multiple of the alignment
  void* p = std::aligned_alloc(64, bytes);
  if (p == nullptr) throw std::bad_alloc();
  return static_cast<T*>(p);
}

// What the kernels read and write: one base pointer and a row stride, so every access is an
// affine index the vectoriser can see through (an array of row pointers defeats it).
struct BatchView {
  double* data;          // rows [16 states | 4 refs | kNumOutputs outputs] x [stride]
  int stride;            // padded aircraft count (int: keeps index arithmetic affine for GCC)
  std::int32_t* status;  // [stride]
  const double* law;     // [kNumLawParams] x [stride]; nullptr for StageLaw::kHeld
  bool wide;             // the AVX-512 copies of the kernels
};

F16_INLINE bool is_finite(double v) { return std::fabs(v) <= DBL_MAX; }

// State and references of aircraft i from the column-major batch block into locals.
F16_INLINE void load_lane(const double* __restrict data, int stride, int i, double* __restrict x,
                          double* __restrict u) {
#pragma GCC unroll 16
  for (int s = 0; s < kNumStates; ++s) x[s] = data[s * stride + i];
#pragma GCC unroll 4
  for (int r = 0; r < kNumRefs; ++r) u[r] = data[(kNumStates + r) * stride + i];
}

// The references of a stage law at stage state x (p: the lane's law parameters).
template <StageLaw LAW>
F16_INLINE void law_refs(const double* __restrict p, const double* __restrict x, double* __restrict u) {
  if constexpr (LAW == StageLaw::kGcas) {
    autopilot_law::gcas(static_cast<GcasMode>(static_cast<int>(p[kLawMode])), x, u);
  } else {
    if (p[kLawMode] == 0.0) autopilot_law::waypoint_toward(p[kLawTargetN], p[kLawTargetE], p[kLawTargetAlt], p[kLawAirspeed], x, u);
    else autopilot_law::waypoint_done(p[kLawTargetAlt], p[kLawAirspeed], x, u);
  }
}

// The closed-loop derivative at a stage: held references, or the law's at this stage's state
// (AeroBench's right-hand side). kHeld compiles to the plain call.
template <AeroModel MODEL, StageLaw LAW>
F16_INLINE ClosedLoopOutputs stage_derivative(const double* __restrict x, const double* __restrict u,
                                              const double* __restrict p) {
  if constexpr (LAW == StageLaw::kHeld) {
    (void)p;
    return closed_loop_derivative<MODEL>(x, u);
  } else {
    (void)u;
    double us[kNumRefs];
    law_refs<LAW>(p, x, us);
    return closed_loop_derivative<MODEL>(x, us);
  }
}

// One aircraft, one fixed step, inlined into the SIMD lane loop of step_block. Frozen lanes
// are computed too (SIMD has no per-lane branches) but their results are discarded.
template <AeroModel MODEL, Integrator INTEGRATOR, StageLaw LAW>
F16_INLINE void step_lane(double* __restrict data, int stride, std::int32_t* __restrict status_arr,
                          const double* __restrict law, int i, double dt, const EnvelopeLimits& lim) {
  const std::int32_t status = status_arr[i];
  double x[kNumStates], u[kNumRefs], p[kNumLawParams];
  load_lane(data, stride, i, x, u);
  if constexpr (LAW != StageLaw::kHeld) {
#pragma GCC unroll 8
    for (int k = 0; k < kNumLawParams; ++k) p[k] = law[k * stride + i];
  }

  double xn[kNumStates];
  if constexpr (INTEGRATOR == Integrator::kRk4) {
    const ClosedLoopOutputs k1 = stage_derivative<MODEL, LAW>(x, u, p);
    double xs[kNumStates];
#pragma GCC unroll 16
    for (int s = 0; s < kNumStates; ++s) xs[s] = x[s] + 0.5 * dt * k1.xdot[s];
    const ClosedLoopOutputs k2 = stage_derivative<MODEL, LAW>(xs, u, p);
#pragma GCC unroll 16
    for (int s = 0; s < kNumStates; ++s) xs[s] = x[s] + 0.5 * dt * k2.xdot[s];
    const ClosedLoopOutputs k3 = stage_derivative<MODEL, LAW>(xs, u, p);
#pragma GCC unroll 16
    for (int s = 0; s < kNumStates; ++s) xs[s] = x[s] + dt * k3.xdot[s];
    const ClosedLoopOutputs k4 = stage_derivative<MODEL, LAW>(xs, u, p);
#pragma GCC unroll 16
    for (int s = 0; s < kNumStates; ++s)
      xn[s] = x[s] + (dt / 6.0) * (k1.xdot[s] + 2.0 * k2.xdot[s] + 2.0 * k3.xdot[s] + k4.xdot[s]);
  } else {
    const ClosedLoopOutputs k1 = stage_derivative<MODEL, LAW>(x, u, p);
#pragma GCC unroll 16
    for (int s = 0; s < kNumStates; ++s) xn[s] = x[s] + dt * k1.xdot[s];
  }

  const std::int32_t verdict = classify_state(xn, lim);
  const bool active = status == kStatusOk;
  const bool accept = active & (verdict == kStatusOk);
#pragma GCC unroll 16
  for (int s = 0; s < kNumStates; ++s) data[s * stride + i] = accept ? xn[s] : x[s];
  status_arr[i] = active ? verdict : status;
}

// One block of kBlock lanes, one step, SIMD across the lanes.
template <AeroModel MODEL, Integrator INTEGRATOR, StageLaw LAW>
F16_INLINE void step_lanes(double* __restrict data, int stride, std::int32_t* __restrict status,
                           const double* __restrict law, int i0, double dt, const EnvelopeLimits& lim) {
#pragma omp simd
  for (int i = i0; i < i0 + F16Batch::kBlock; ++i)
    step_lane<MODEL, INTEGRATOR, LAW>(data, stride, status, law, i, dt, lim);
}

// Kept out of line with restrict pointers and scalars by value: that is the shape GCC's
// vectoriser reliably turns into full-width SIMD.
template <AeroModel MODEL, Integrator INTEGRATOR, StageLaw LAW>
__attribute__((noinline)) void step_block(double* __restrict data, int stride, std::int32_t* __restrict status,
                                          const double* __restrict law, int i0, double dt, EnvelopeLimits lim) {
  step_lanes<MODEL, INTEGRATOR, LAW>(data, stride, status, law, i0, dt, lim);
}

#if F16_WIDE_KERNELS
template <AeroModel MODEL, Integrator INTEGRATOR, StageLaw LAW>
__attribute__((noinline)) F16_WIDE_TARGET void step_block_wide(double* __restrict data, int stride,
                                                               std::int32_t* __restrict status,
                                                               const double* __restrict law, int i0, double dt,
                                                               EnvelopeLimits lim) {
  step_lanes<MODEL, INTEGRATOR, LAW>(data, stride, status, law, i0, dt, lim);
}
#endif

template <AeroModel MODEL, Integrator INTEGRATOR, StageLaw LAW>
void step_kernel(const BatchView& v, double dt, int substeps, const EnvelopeLimits& lim) {
  const int n_blocks = v.stride / F16Batch::kBlock;
#pragma omp parallel for schedule(static)
  for (int b = 0; b < n_blocks; ++b) {
    // Substeps inside the block loop: the block's state stays in L1 for the whole call.
    for (int k = 0; k < substeps; ++k) {
#if F16_WIDE_KERNELS
      if (v.wide) {
        step_block_wide<MODEL, INTEGRATOR, LAW>(v.data, v.stride, v.status, v.law, b * F16Batch::kBlock, dt, lim);
        continue;
      }
#endif
      step_block<MODEL, INTEGRATOR, LAW>(v.data, v.stride, v.status, v.law, b * F16Batch::kBlock, dt, lim);
    }
  }
}

// Outputs of one aircraft; like step_lane, the locals live in an inlined function rather than
// in the SIMD loop body, where GCC would turn them into per-lane memory arrays.
template <AeroModel MODEL, StageLaw LAW>
F16_INLINE void outputs_lane(double* __restrict data, int stride, const double* __restrict law, int i) {
  double x[kNumStates], u[kNumRefs];
  load_lane(data, stride, i, x, u);
  if constexpr (LAW != StageLaw::kHeld) {
    double p[kNumLawParams];
#pragma GCC unroll 8
    for (int k = 0; k < kNumLawParams; ++k) p[k] = law[k * stride + i];
    law_refs<LAW>(p, x, u);
#pragma GCC unroll 4
    for (int r = 0; r < kNumRefs; ++r) data[(kNumStates + r) * stride + i] = u[r];
  }
  const ClosedLoopOutputs o = closed_loop_derivative<MODEL>(x, u);
  double* out = data + (kNumStates + kNumRefs) * stride + i;
  out[kOutNz * stride] = o.nz_g;
  out[kOutPs * stride] = o.ps_radps;
  out[kOutNyR * stride] = o.ny_r;
  out[kOutThrottle * stride] = o.surfaces.throttle;
  out[kOutElevator * stride] = o.surfaces.elevator_deg;
  out[kOutAileron * stride] = o.surfaces.aileron_deg;
  out[kOutRudder * stride] = o.surfaces.rudder_deg;
  out[kOutVn * stride] = o.xdot[kPn];
  out[kOutVe * stride] = o.xdot[kPe];
  out[kOutVu * stride] = o.xdot[kAlt];
}

template <AeroModel MODEL, StageLaw LAW>
__attribute__((noinline)) void outputs_block(double* __restrict data, int stride, const double* __restrict law, int i0) {
#pragma omp simd
  for (int i = i0; i < i0 + F16Batch::kBlock; ++i) outputs_lane<MODEL, LAW>(data, stride, law, i);
}

#if F16_WIDE_KERNELS
template <AeroModel MODEL, StageLaw LAW>
__attribute__((noinline)) F16_WIDE_TARGET void outputs_block_wide(double* __restrict data, int stride,
                                                                  const double* __restrict law, int i0) {
#pragma omp simd
  for (int i = i0; i < i0 + F16Batch::kBlock; ++i) outputs_lane<MODEL, LAW>(data, stride, law, i);
}
#endif

template <AeroModel MODEL, StageLaw LAW>
void outputs_kernel(const BatchView& v) {
  const int n_blocks = v.stride / F16Batch::kBlock;
#pragma omp parallel for schedule(static)
  for (int b = 0; b < n_blocks; ++b) {
#if F16_WIDE_KERNELS
    if (v.wide) {
      outputs_block_wide<MODEL, LAW>(v.data, v.stride, v.law, b * F16Batch::kBlock);
      continue;
    }
#endif
    outputs_block<MODEL, LAW>(v.data, v.stride, v.law, b * F16Batch::kBlock);
  }
}

// The kernels of one model and integrator for the batch's stage law.
template <AeroModel MODEL, Integrator INTEGRATOR>
void step_for_law(StageLaw law, const BatchView& v, double dt, int substeps, const EnvelopeLimits& lim) {
  switch (law) {
    case StageLaw::kHeld: step_kernel<MODEL, INTEGRATOR, StageLaw::kHeld>(v, dt, substeps, lim); break;
    case StageLaw::kGcas: step_kernel<MODEL, INTEGRATOR, StageLaw::kGcas>(v, dt, substeps, lim); break;
    case StageLaw::kWaypoint: step_kernel<MODEL, INTEGRATOR, StageLaw::kWaypoint>(v, dt, substeps, lim); break;
  }
}

template <AeroModel MODEL, StageLaw LAW>
void outputs_range(const BatchView& v, int first, int count) {
  for (int i = first; i < first + count; ++i) outputs_lane<MODEL, LAW>(v.data, v.stride, v.law, i);
}

template <AeroModel MODEL>
void outputs_range_for_law(StageLaw law, const BatchView& v, int first, int count) {
  switch (law) {
    case StageLaw::kHeld: outputs_range<MODEL, StageLaw::kHeld>(v, first, count); break;
    case StageLaw::kGcas: outputs_range<MODEL, StageLaw::kGcas>(v, first, count); break;
    case StageLaw::kWaypoint: outputs_range<MODEL, StageLaw::kWaypoint>(v, first, count); break;
  }
}

template <AeroModel MODEL>
void outputs_for_law(StageLaw law, const BatchView& v) {
  switch (law) {
    case StageLaw::kHeld: outputs_kernel<MODEL, StageLaw::kHeld>(v); break;
    case StageLaw::kGcas: outputs_kernel<MODEL, StageLaw::kGcas>(v); break;
    case StageLaw::kWaypoint: outputs_kernel<MODEL, StageLaw::kWaypoint>(v); break;
  }
}

}  // namespace

F16Batch::F16Batch(const F16BatchConfig& config)
    : config_(config), wide_(config.isa == KernelIsa::kWidest && wide_kernels_available()) {
  if (config.n_env < 1 || config.n_agent < 1) {
    throw std::invalid_argument("F16Batch: n_env and n_agent must be >= 1 (got " + std::to_string(config.n_env) +
                                " x " + std::to_string(config.n_agent) + ")");
  }
  size_ = config.n_env * config.n_agent;
  padded_ = (size_ + kBlock - 1) / kBlock * kBlock;
  const std::size_t rows = kNumStates + kNumRefs + kNumOutputs;
  data_.reset(aligned_array<double>(rows * padded_));
  status_.reset(aligned_array<std::int32_t>(padded_));
  std::memset(data_.get(), 0, rows * padded_ * sizeof(double));
  // Every lane, padding included, starts at the LQR design point so no lane computes garbage.
  StateVector xeq{};
  #pragma GCC unroll 16
  for (int s = 0; s < kNumPlantStates; ++s) xeq[s] = lqr::kXequil[s];
  for (int i = 0; i < padded_; ++i) {
    #pragma GCC unroll 16
    for (int s = 0; s < kNumStates; ++s) state(s)[i] = xeq[s];
    status_[i] = i < size_ ? kStatusOk : kStatusPadding;
  }
  if (config.stage_law != StageLaw::kHeld) {
    // Every lane starts in the law's first mode (GCAS standby; waypoint toward (0, 0, 0)) at
    // AeroBench's set point, so padding lanes compute finite numbers.
    law_.reset(aligned_array<double>(kNumLawParams * static_cast<std::size_t>(padded_)));
    std::memset(law_.get(), 0, kNumLawParams * static_cast<std::size_t>(padded_) * sizeof(double));
    for (int i = 0; i < padded_; ++i) {
      law(kLawTargetAlt)[i] = lqr::kXequil[kAlt];
      law(kLawAirspeed)[i] = WaypointConstants::kAirspeedFtps;
    }
  }
}

double* F16Batch::law(int p) {
  if (!law_) throw std::logic_error("F16Batch::law: this batch holds its references (stage_law held)");
  return law_.get() + static_cast<std::size_t>(p) * padded_;
}

const double* F16Batch::law(int p) const {
  if (!law_) throw std::logic_error("F16Batch::law: this batch holds its references (stage_law held)");
  return law_.get() + static_cast<std::size_t>(p) * padded_;
}

void F16Batch::reset_aircraft(int i, const StateVector& x, const RefVector& u_ref) {
  #pragma GCC unroll 16
  for (int s = 0; s < kNumStates; ++s) state(s)[i] = x[s];
  #pragma GCC unroll 16
  for (int r = 0; r < kNumRefs; ++r) ref(r)[i] = u_ref[r];
  status_[i] = kStatusOk;
}

StateVector F16Batch::aircraft_state(int i) const {
  StateVector x;
  #pragma GCC unroll 16
  for (int s = 0; s < kNumStates; ++s) x[s] = state(s)[i];
  return x;
}

namespace {
BatchView make_view(F16Batch& b, double* data, int padded, const double* law) {
  return BatchView{data, padded, b.status(), law, b.uses_wide_kernels()};
}
}  // namespace

int F16Batch::step(double dt_s, int substeps) {
  const BatchView v = make_view(*this, data_.get(), padded_, law_.get());
  int ok_before = 0;
  for (int i = 0; i < size_; ++i) ok_before += status_[i] == kStatusOk;
  const EnvelopeLimits& lim = config_.limits;
  const StageLaw law = config_.stage_law;
  if (config_.model == AeroModel::kMorelli) {
    if (config_.integrator == Integrator::kRk4) step_for_law<AeroModel::kMorelli, Integrator::kRk4>(law, v, dt_s, substeps, lim);
    else step_for_law<AeroModel::kMorelli, Integrator::kEuler>(law, v, dt_s, substeps, lim);
  } else {
    if (config_.integrator == Integrator::kRk4) step_for_law<AeroModel::kStevens, Integrator::kRk4>(law, v, dt_s, substeps, lim);
    else step_for_law<AeroModel::kStevens, Integrator::kEuler>(law, v, dt_s, substeps, lim);
  }
  int ok_after = 0;
  for (int i = 0; i < size_; ++i) ok_after += status_[i] == kStatusOk;
  return ok_before - ok_after;
}

void F16Batch::evaluate_outputs() {
  const BatchView v = make_view(*this, data_.get(), padded_, law_.get());
  if (config_.model == AeroModel::kMorelli) outputs_for_law<AeroModel::kMorelli>(config_.stage_law, v);
  else outputs_for_law<AeroModel::kStevens>(config_.stage_law, v);
}

void F16Batch::evaluate_outputs(int first, int count) {
  if (first < 0 || count < 0 || first + count > size_)
    throw std::out_of_range("F16Batch::evaluate_outputs: aircraft [" + std::to_string(first) + ", " +
                            std::to_string(first + count) + ") outside [0, " + std::to_string(size_) + ")");
  const BatchView v = make_view(*this, data_.get(), padded_, law_.get());
  if (config_.model == AeroModel::kMorelli) outputs_range_for_law<AeroModel::kMorelli>(config_.stage_law, v, first, count);
  else outputs_range_for_law<AeroModel::kStevens>(config_.stage_law, v, first, count);
}

}  // namespace f16race::dynamics

namespace f16race::dynamics {

void F16Batch::save_state(std::ostream& out) const {
  const std::int64_t header[2] = {size_, padded_};
  out.write(reinterpret_cast<const char*>(header), sizeof header);
  const std::size_t rows = kNumStates + kNumRefs + kNumOutputs;
  out.write(reinterpret_cast<const char*>(data_.get()), static_cast<std::streamsize>(rows * padded_ * sizeof(double)));
  out.write(reinterpret_cast<const char*>(status_.get()), static_cast<std::streamsize>(padded_ * sizeof(std::int32_t)));
  // Law rows only with a law, so a held batch's snapshot (the race env's) keeps its format.
  if (law_) out.write(reinterpret_cast<const char*>(law_.get()), static_cast<std::streamsize>(kNumLawParams * padded_ * sizeof(double)));
}

void F16Batch::load_state(std::istream& in) {
  std::int64_t header[2] = {0, 0};
  in.read(reinterpret_cast<char*>(header), sizeof header);
  if (!in || header[0] != size_ || header[1] != padded_)
    throw std::runtime_error("simulator snapshot is for " + std::to_string(header[0]) + " aircraft, this batch has " +
                             std::to_string(size_));
  const std::size_t rows = kNumStates + kNumRefs + kNumOutputs;
  in.read(reinterpret_cast<char*>(data_.get()), static_cast<std::streamsize>(rows * padded_ * sizeof(double)));
  in.read(reinterpret_cast<char*>(status_.get()), static_cast<std::streamsize>(padded_ * sizeof(std::int32_t)));
  if (law_) in.read(reinterpret_cast<char*>(law_.get()), static_cast<std::streamsize>(kNumLawParams * padded_ * sizeof(double)));
  if (!in) throw std::runtime_error("simulator snapshot is truncated");
}

}  // namespace f16race::dynamics
