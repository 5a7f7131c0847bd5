#pragma once
// How long an idle OpenMP thread spins before it sleeps. libgomp's default (300 000 spins when
// OMP_WAIT_POLICY is unset) costs nothing on an idle machine, but beside another session's busy
// process a spinning thread spends its session's share of the CPU that the working thread needs:
// bench train ran >45x slower there; at 1 000 spins 1.8x, 4 % below the default when alone
// (docs/performance.md, "A shared machine").

namespace f16race::io {

// The spin count f16race runs with when the user chose none (measured: docs/performance.md).
constexpr const char* kOpenmpSpinCount = "1000";

// Sets GOMP_SPINCOUNT to kOpenmpSpinCount when neither it nor OMP_WAIT_POLICY is set (a user's
// choice is kept) and returns true when it changed the environment: libgomp reads it when it
// loads, so the process must then run itself again.
bool bound_openmp_spins();

}  // namespace f16race::io
