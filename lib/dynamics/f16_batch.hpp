#pragma once
// Batched F-16 simulator: n_env x n_agent aircraft in structure-of-arrays layout, advanced
// together by fixed-step RK4 (or Euler) on the closed-loop AeroBench model, OpenMP over blocks
// of aircraft and SIMD across each block. Aircraft index = env * n_agent + agent.
//
// Results are bit-identical for any thread count: every aircraft always sits in the same lane
// of the same fixed-size block, so the same instructions compute it whichever thread runs it.
#include <cstdint>
#include <iosfwd>
#include <memory>

#include "dynamics/envelope.hpp"
#include "dynamics/state.hpp"

namespace f16race::dynamics {

enum class Integrator { kRk4, kEuler };
bool parse_integrator(const char* text, Integrator* out);
const char* integrator_name(Integrator integrator);

// Quantities derived from the current state by evaluate_outputs().
enum OutputIndex : int {
  kOutNz = 0,         // normal load factor [g]
  kOutPs = 1,         // stability roll rate [rad/s]
  kOutNyR = 2,        // Ny + r [mixed]
  kOutThrottle = 3,   // throttle command after saturation [0..1]
  kOutElevator = 4,   // [deg]
  kOutAileron = 5,    // [deg]
  kOutRudder = 6,     // [deg]
  kOutVn = 7,         // north velocity [ft/s]
  kOutVe = 8,         // east velocity [ft/s]
  kOutVu = 9,         // climb rate [ft/s]
  kNumOutputs = 10
};

// What sets the inner loop's references during a step. AeroBench evaluates its autopilots inside
// the ODE's right-hand side, so a law is evaluated at every RK stage on the stage's state; its
// discrete mode (law row kLawMode) changes only between steps, where the owner puts it
// (autopilot_batch.hpp does it at output samples, as AeroBench's run_f16_sim).
enum class StageLaw {
  kHeld,      // the ref() rows, constant over a step (the race env's actions)
  kGcas,      // AeroBench's GCAS: kLawMode holds a GcasMode
  kWaypoint,  // AeroBench's waypoint autopilot toward kLawTarget*, at kLawAirspeed; kLawMode 1: done
};
const char* stage_law_name(StageLaw law);  // "held", "gcas", "waypoint"

// Per-aircraft law parameters (rows of law()); unused rows of a law are ignored.
enum LawParamIndex : int {
  kLawMode = 0,        // GCAS: GcasMode as a number; waypoint: 0 toward the target, 1 done (wings level)
  kLawTargetN = 1,     // waypoint north [ft]
  kLawTargetE = 2,     // waypoint east [ft]
  kLawTargetAlt = 3,   // waypoint altitude [ft] (done: the altitude held)
  kLawAirspeed = 4,    // airspeed set point [ft/s]
  kNumLawParams = 5
};

// The instructions of the step and output kernels: the widest this CPU has (AVX-512 where the
// build's own target lacks it, chosen at run time), or the build's own (x86-64-v3's AVX2 in the
// reproducible build). Both give the same bits, which a test holds: every aircraft is computed
// alone in its lane, by the same operations, whatever the vector's width.
enum class KernelIsa { kWidest, kBuild };
// True when this binary holds the AVX-512 kernels and this CPU runs them.
bool wide_kernels_available();

struct F16BatchConfig {
  int n_env = 1;
  int n_agent = 1;
  AeroModel model = AeroModel::kMorelli;
  Integrator integrator = Integrator::kRk4;
  EnvelopeLimits limits{};
  StageLaw stage_law = StageLaw::kHeld;
  KernelIsa isa = KernelIsa::kWidest;
};

class F16Batch {
 public:
  // Aircraft are processed in blocks of this many lanes; the arrays are padded to whole blocks.
  static constexpr int kBlock = 16;

  explicit F16Batch(const F16BatchConfig& config);
  F16Batch(const F16Batch&) = delete;
  F16Batch& operator=(const F16Batch&) = delete;
  F16Batch(F16Batch&&) noexcept = default;
  F16Batch& operator=(F16Batch&&) noexcept = default;

  int n_env() const { return config_.n_env; }
  int n_agent() const { return config_.n_agent; }
  int size() const { return size_; }                // n_env * n_agent
  int padded_size() const { return padded_; }       // size rounded up to kBlock
  const F16BatchConfig& config() const { return config_; }
  bool uses_wide_kernels() const { return wide_; }  // the AVX-512 kernels (KernelIsa)

  // State row s (StateIndex): [n_env * n_agent], contiguous, 64-byte aligned.
  double* state(int s) { return data_.get() + static_cast<std::size_t>(s) * padded_; }
  const double* state(int s) const { return data_.get() + static_cast<std::size_t>(s) * padded_; }
  // Outer-loop reference r (RefIndex): [n_env * n_agent]. kHeld: the input, constant over a
  // step. A law: its references at the states of the last evaluate_outputs() (an output).
  double* ref(int r) { return data_.get() + static_cast<std::size_t>(kNumStates + r) * padded_; }
  const double* ref(int r) const { return data_.get() + static_cast<std::size_t>(kNumStates + r) * padded_; }
  // Output o (OutputIndex): [n_env * n_agent], valid after evaluate_outputs().
  const double* output(int o) const {
    return data_.get() + static_cast<std::size_t>(kNumStates + kNumRefs + o) * padded_;
  }
  // Law parameter p (LawParamIndex): [n_env * n_agent]; only with a stage law (throws otherwise).
  double* law(int p);
  const double* law(int p) const;
  // Per-aircraft AircraftStatus: [n_env * n_agent].
  std::int32_t* status() { return status_.get(); }
  const std::int32_t* status() const { return status_.get(); }

  // Writes one aircraft's 16 states, its references, and marks it kStatusOk.
  void reset_aircraft(int i, const StateVector& x, const RefVector& u_ref);
  StateVector aircraft_state(int i) const;

  // Advances every kStatusOk aircraft by `substeps` steps of dt_s. Returns how many aircraft
  // were frozen by this call; their status says why and their state is the last valid one.
  int step(double dt_s, int substeps = 1);

  // Fills output() rows from the current states and references (with a stage law, the ref()
  // rows first, from the law at the current states and modes).
  void evaluate_outputs();
  // The same for aircraft [first, first + count) only, one lane at a time on the calling thread
  // (for a caller that resets some aircraft inside its own parallel loop).
  void evaluate_outputs(int first, int count);

  // Exact snapshot of every state, reference, output, law parameter and status (for checkpoints that resume
  // bit-identically). load_state throws std::runtime_error on a size mismatch or short read.
  void save_state(std::ostream& out) const;
  void load_state(std::istream& in);

 private:
  F16BatchConfig config_;
  bool wide_ = false;
  int size_ = 0;
  int padded_ = 0;
  struct FreeDeleter {
    void operator()(void* p) const;
  };
  std::unique_ptr<double[], FreeDeleter> data_;          // [16 + 4 + kNumOutputs][padded]
  std::unique_ptr<std::int32_t[], FreeDeleter> status_;  // [padded]
  std::unique_ptr<double[], FreeDeleter> law_;           // [kNumLawParams][padded], with a stage law only
};

}  // namespace f16race::dynamics
