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

struct F16BatchConfig {
  int n_env = 1;
  int n_agent = 1;
  AeroModel model = AeroModel::kMorelli;
  Integrator integrator = Integrator::kRk4;
  EnvelopeLimits limits{};
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

  // State row s (StateIndex): [n_env * n_agent], contiguous, 64-byte aligned.
  double* state(int s) { return data_.get() + static_cast<std::size_t>(s) * padded_; }
  const double* state(int s) const { return data_.get() + static_cast<std::size_t>(s) * padded_; }
  // Outer-loop reference r (RefIndex): [n_env * n_agent], held constant over a step.
  double* ref(int r) { return data_.get() + static_cast<std::size_t>(kNumStates + r) * padded_; }
  const double* ref(int r) const { return data_.get() + static_cast<std::size_t>(kNumStates + r) * padded_; }
  // Output o (OutputIndex): [n_env * n_agent], valid after evaluate_outputs().
  const double* output(int o) const {
    return data_.get() + static_cast<std::size_t>(kNumStates + kNumRefs + o) * padded_;
  }
  // Per-aircraft AircraftStatus: [n_env * n_agent].
  std::int32_t* status() { return status_.get(); }
  const std::int32_t* status() const { return status_.get(); }

  // Writes one aircraft's 16 states, its references, and marks it kStatusOk.
  void reset_aircraft(int i, const StateVector& x, const RefVector& u_ref);
  StateVector aircraft_state(int i) const;

  // Advances every kStatusOk aircraft by `substeps` steps of dt_s. Returns how many aircraft
  // were frozen by this call; their status says why and their state is the last valid one.
  int step(double dt_s, int substeps = 1);

  // Fills output() rows from the current states and references.
  void evaluate_outputs();

  // Exact snapshot of every state, reference, output and status (for checkpoints that resume
  // bit-identically). load_state throws std::runtime_error on a size mismatch or short read.
  void save_state(std::ostream& out) const;
  void load_state(std::istream& in);

 private:
  F16BatchConfig config_;
  int size_ = 0;
  int padded_ = 0;
  struct FreeDeleter {
    void operator()(void* p) const;
  };
  std::unique_ptr<double[], FreeDeleter> data_;          // [16 + 4 + kNumOutputs][padded]
  std::unique_ptr<std::int32_t[], FreeDeleter> status_;  // [padded]
};

}  // namespace f16race::dynamics
