#pragma once
// The observation layout, once: every entry of the ego, goal, ado and task rows with its offset,
// width and meaning. RaceEnv::write_observations writes through these offsets, the widths feed
// models::ObsDims (train/obs_views.hpp), the TorchScript export's README lists these meanings,
// and docs/race.md's tables are held to them by a test (tests/race/test_observation_spec.cpp).
// Torch-free and constexpr: the offsets compile to the same immediates as literals.
#include <cstddef>

namespace f16race::race {

struct ObsField {
  int offset;
  int width;
  const char* meaning;
};

// Sum of the widths; with contiguous() the fields tile [0, width) in order.
template <std::size_t N>
constexpr int fields_width(const ObsField (&fields)[N]) {
  int w = 0;
  for (std::size_t k = 0; k < N; ++k) w += fields[k].width;
  return w;
}
template <std::size_t N>
constexpr bool contiguous(const ObsField (&fields)[N]) {
  int next = 0;
  for (std::size_t k = 0; k < N; ++k) {
    if (fields[k].offset != next) return false;
    next += fields[k].width;
  }
  return true;
}

// ego: the aircraft's own state (s-bar), angles as sin/cos, scaled to O(1).
inline constexpr int kEgoVt = 0, kEgoAttitudeTrig = 1, kEgoBodyRates = 11, kEgoAltitude = 14, kEgoPower = 15,
                     kEgoIntegrators = 16, kEgoNz = 19;
inline constexpr ObsField kEgoFields[] = {
    {kEgoVt, 1, "vt / 1000 ft/s"},
    {kEgoAttitudeTrig, 10, "sin, cos of α, β, φ, θ, ψ (pairs in that order)"},
    {kEgoBodyRates, 3, "p / 2, q, r [rad/s], each clamped to ±10"},
    {kEgoAltitude, 1, "altitude / 10 000 ft"},
    {kEgoPower, 1, "engine power state / 100"},
    {kEgoIntegrators, 3, "∫(Nz−Nz_ref)/5, ∫(ps−ps_ref)/2, ∫(Ny+r−Ny_r_ref)/2, clamped ±10"},
    {kEgoNz, 1, "Nz (simulator output, end of step) / 5 g, clamped ±10"},
};
inline constexpr int kEgoDim = fields_width(kEgoFields);
static_assert(kEgoDim == 20 && contiguous(kEgoFields), "ego layout");

// goal (LL input): the lane the high level chose, relative to the aircraft's own.
inline constexpr int kGoalAhead = 0, kGoalLaneRight = 1, kGoalLaneUp = 2;
inline constexpr ObsField kGoalFields[] = {
    {kGoalAhead, 1, "distance ahead along the track to the goal's center-line point / the goal distance, [0, 10]"},
    {kGoalLaneRight, 1, "the goal's offset right in its tube cross-section minus the aircraft's, / radius, ±10"},
    {kGoalLaneUp, 1, "the same, up"},
};
inline constexpr int kGoalDim = fields_width(kGoalFields);
static_assert(kGoalDim == 3 && contiguous(kGoalFields), "goal layout");

// ado: one row per other aircraft, in the ego's heading frame (x forward, y right, z up).
inline constexpr int kAdoRange = 0, kAdoAzimuth = 1, kAdoSinElevation = 3, kAdoRelVelocity = 4, kAdoProgress = 7,
                     kAdoClosing = 8, kAdoTimeToClosest = 9, kAdoMissDistance = 10, kAdoSameTeam = 11, kAdoAlive = 12;
inline constexpr ObsField kAdoFields[] = {
    {kAdoRange, 1, "range / 5 000 ft, ≤ 10"},
    {kAdoAzimuth, 2, "y/ρ, x/ρ: sin and cos of azimuth (ρ horizontal range; 0, 1 if ρ ≤ 1e-3 ft)"},
    {kAdoSinElevation, 1, "Δz / range: sin of elevation"},
    {kAdoRelVelocity, 3, "relative velocity (other − ego) along x, y, up, / 500 ft/s"},
    {kAdoProgress, 1, "(progress_other − progress_ego) / 5 000 ft, clamped ±10"},
    {kAdoClosing, 1, "closing speed (− d range / dt) / 500 ft/s, clamped ±10"},
    {kAdoTimeToClosest, 1, "time to the closest approach if both hold their velocity / 10 s, clamped [0, 1]"},
    {kAdoMissDistance, 1, "distance at that closest approach / 1 000 ft, clamped [0, 10]"},
    {kAdoSameTeam, 1, "1 if same team, else 0"},
    {kAdoAlive, 1, "1 if alive, else 0 (the entries before are zero for a terminated aircraft)"},
};
inline constexpr int kAdoDim = fields_width(kAdoFields);
static_assert(kAdoDim == 13 && contiguous(kAdoFields), "ado layout");

// task: kPreviewWidth entries per preview point (p = 0 .. preview_points − 1, at progress +
// (p+1)·preview_spacing_ft), then the tail, whose offsets count from preview_points·kPreviewWidth.
inline constexpr int kPreviewRange = 0, kPreviewAzimuth = 1, kPreviewSinElevation = 3, kPreviewRadius = 4;
inline constexpr ObsField kPreviewFields[] = {
    {kPreviewRange, 1, "range / 5 000 ft, ≤ 10"},
    {kPreviewAzimuth, 2, "sin, cos of azimuth in the heading frame"},
    {kPreviewSinElevation, 1, "sin of elevation"},
    {kPreviewRadius, 1, "local tube radius / 2 000 ft"},
};
inline constexpr int kPreviewWidth = fields_width(kPreviewFields);
static_assert(kPreviewWidth == 5 && contiguous(kPreviewFields), "preview layout");

inline constexpr int kTaskOffsets = 0, kTaskCenterDistance = 2, kTaskProgress = 3, kTaskTimeLeft = 4,
                     kTaskHlTimeLeft = 5, kTaskEgoRank = 6, kTaskTeamRank = 7;
inline constexpr ObsField kTaskTailFields[] = {
    {kTaskOffsets, 2, "lateral / R, vertical / R, clamped ±10"},
    {kTaskCenterDistance, 1, "distance from center-line / R, clamped [0, 10]"},
    {kTaskProgress, 1, "progress / track length"},
    {kTaskTimeLeft, 1, "1 − race time / time limit"},
    {kTaskHlTimeLeft, 1, "HL time left / dt_hl_s (≥ 0)"},
    {kTaskEgoRank, 1, "ego rank / (n_agent − 1)"},
    {kTaskTeamRank, 1, "team rank (0, 0.5, 1)"},
};
inline constexpr int kTaskTailWidth = fields_width(kTaskTailFields);
static_assert(kTaskTailWidth == 8 && contiguous(kTaskTailFields), "task tail layout");

constexpr int task_width(int preview_points) { return kPreviewWidth * preview_points + kTaskTailWidth; }

}  // namespace f16race::race
