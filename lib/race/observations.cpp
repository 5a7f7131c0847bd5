// Every observation of one env in one pass after its step: ego state, the HL goal, the other
// aircraft (ado), the track preview and the task entries, into the env's rows of the
// preallocated float buffers (race/observation_spec.hpp has every entry).
//
// Float arithmetic where the buffers are float (float sqrt/div are twice as fast), and every
// per-aircraft, per-pair and per-preview-point computation is a straight loop over small local
// arrays that GCC vectorises (`omp simd`); only gathers and the final scatter into the
// interleaved buffers are scalar. Measured 2.5x faster than the row-by-row version.
#include <algorithm>
#include <cmath>

#include "dynamics/vector_math.hpp"
#include "race/race_env.hpp"

namespace f16race::race {

using namespace f16race::dynamics;

namespace {

constexpr int kMaxAgents = 16;   // 8 vs 8
constexpr int kMaxPreview = 64;  // race_config: preview_points <= 64

float clampf(double v, double lo, double hi) { return static_cast<float>(std::min(std::max(v, lo), hi)); }

// The env's aircraft as the passes below read them, [agent] (attitude: [angle][agent]). Padded to
// kMaxAgents with zeros: the vector loops run the full fixed length (one 16-lane iteration),
// which is faster than a loop of na iterations and its remainder.
struct PackState {
  // Positions relative to the first aircraft keep float precision on long tracks.
  float pn_rel_ft[kMaxAgents] = {}, pe_rel_ft[kMaxAgents] = {}, pu_rel_ft[kMaxAgents] = {};  // north/east/up
  float vn_ftps[kMaxAgents] = {}, ve_ftps[kMaxAgents] = {}, vu_ftps[kMaxAgents] = {};
  float prog[kMaxAgents] = {}, alive_f[kMaxAgents] = {};
  float sn[5][kMaxAgents], cs[5][kMaxAgents];  // sin, cos of alpha, beta, phi, theta, psi
};

void gather_pack(const F16Batch& sim, int base, int na, const double* progress_ft, const std::uint8_t* alive,
                 PackState* s) {
  float ang[5][kMaxAgents] = {};
  for (int a = 0; a < na; ++a) {
    const int i = base + a;
    s->pn_rel_ft[a] = static_cast<float>(sim.state(kPn)[i] - sim.state(kPn)[base]);
    s->pe_rel_ft[a] = static_cast<float>(sim.state(kPe)[i] - sim.state(kPe)[base]);
    s->pu_rel_ft[a] = static_cast<float>(sim.state(kAlt)[i] - sim.state(kAlt)[base]);
    s->vn_ftps[a] = static_cast<float>(sim.output(kOutVn)[i]);
    s->ve_ftps[a] = static_cast<float>(sim.output(kOutVe)[i]);
    s->vu_ftps[a] = static_cast<float>(sim.output(kOutVu)[i]);
    s->prog[a] = static_cast<float>((progress_ft[i] - progress_ft[base]) / 5000.0);
    s->alive_f[a] = alive[i] ? 1.0f : 0.0f;
    ang[0][a] = static_cast<float>(sim.state(kAlpha)[i]);
    ang[1][a] = static_cast<float>(sim.state(kBeta)[i]);
    ang[2][a] = static_cast<float>(sim.state(kPhi)[i]);
    ang[3][a] = static_cast<float>(sim.state(kTheta)[i]);
    ang[4][a] = static_cast<float>(sim.state(kPsi)[i]);
  }
  // Attitude trig, one 16-lane float pass per angle (the observations are float; float sin/cos
  // is exact to ~2e-7 here). The bound is a runtime 16 on purpose: with a constant one GCC
  // unrolls the loop fully and then fails to if-convert it.
  const int na_pad = (na + 15) / 16 * 16;
  for (int k = 0; k < 5; ++k) {
#pragma omp simd
    for (int a = 0; a < na_pad; ++a) vmath::sincosf(ang[k][a], &s->sn[k][a], &s->cs[k][a]);
  }
}

// ego: the env's rows [na, kEgoDim].
void write_ego_rows(const F16Batch& sim, int base, int na, const PackState& s, float* ego) {
  for (int a = 0; a < na; ++a) {
    const int i = base + a;
    float* o = ego + static_cast<std::size_t>(a) * kEgoDim;
    o[kEgoVt] = static_cast<float>(sim.state(kVt)[i] / 1000.0);
    for (int k = 0; k < 5; ++k) {
      o[kEgoAttitudeTrig + 2 * k] = s.sn[k][a];
      o[kEgoAttitudeTrig + 1 + 2 * k] = s.cs[k][a];
    }
    o[kEgoBodyRates] = clampf(sim.state(kP)[i] / 2.0, -10.0, 10.0);
    o[kEgoBodyRates + 1] = clampf(sim.state(kQ)[i], -10.0, 10.0);
    o[kEgoBodyRates + 2] = clampf(sim.state(kR)[i], -10.0, 10.0);
    o[kEgoAltitude] = static_cast<float>(sim.state(kAlt)[i] / 10000.0);
    o[kEgoPower] = static_cast<float>(sim.state(kPow)[i] / 100.0);
    o[kEgoIntegrators] = clampf(sim.state(kIntNz)[i] / 5.0, -10.0, 10.0);
    o[kEgoIntegrators + 1] = clampf(sim.state(kIntPs)[i] / 2.0, -10.0, 10.0);
    o[kEgoIntegrators + 2] = clampf(sim.state(kIntNyR)[i] / 2.0, -10.0, 10.0);
    o[kEgoNz] = clampf(sim.output(kOutNz)[i] / 5.0, -10.0, 10.0);
  }
}

// Features of every aircraft b as seen from a ([feature][b], the geometric entries before the
// team and alive flags); a dead b gets zeros.
void ado_features(const PackState& s, int a, float (*f)[kMaxAgents]) {
  const float ca = s.cs[4][a], sa = s.sn[4][a];
#pragma omp simd
  for (int b = 0; b < kMaxAgents; ++b) {
    // North/east/up differences, then the ego's heading frame (_hdg): x forward, y right.
    const float dn = s.pn_rel_ft[b] - s.pn_rel_ft[a], de = s.pe_rel_ft[b] - s.pe_rel_ft[a],
                du = s.pu_rel_ft[b] - s.pu_rel_ft[a];
    const float h2 = dn * dn + de * de, rh = std::sqrt(h2), r = std::sqrt(h2 + du * du);
    const float x_hdg = ca * dn + sa * de, y_hdg = -sa * dn + ca * de;
    const float inv_rh = rh > 1e-3f ? 1.0f / rh : 0.0f, inv_r = r > 1e-3f ? 1.0f / r : 0.0f;
    const float vn = s.vn_ftps[b] - s.vn_ftps[a], ve = s.ve_ftps[b] - s.ve_ftps[a];
    // Masked by a multiply (GCC does not vectorise the select here): a dead aircraft's frozen
    // state is its last finite one, so m = 0 gives exact zeros.
    const float m = s.alive_f[b];
    f[kAdoRange][b] = m * std::min(r * (1.0f / 5000.0f), 10.0f);
    f[kAdoAzimuth][b] = m * (inv_rh > 0.0f ? y_hdg * inv_rh : 0.0f);
    f[kAdoAzimuth + 1][b] = m * (inv_rh > 0.0f ? x_hdg * inv_rh : 1.0f);
    f[kAdoSinElevation][b] = m * (du * inv_r);
    f[kAdoRelVelocity][b] = m * ((ca * vn + sa * ve) * (1.0f / 500.0f));
    f[kAdoRelVelocity + 1][b] = m * ((-sa * vn + ca * ve) * (1.0f / 500.0f));
    f[kAdoRelVelocity + 2][b] = m * ((s.vu_ftps[b] - s.vu_ftps[a]) * (1.0f / 500.0f));
    f[kAdoProgress][b] = m * std::min(std::max(s.prog[b] - s.prog[a], -10.0f), 10.0f);
    // Closest approach if both hold their velocity (what TCAS computes): when, and how close.
    const float vu = s.vu_ftps[b] - s.vu_ftps[a];
    const float rv = dn * vn + de * ve + du * vu, v2 = vn * vn + ve * ve + vu * vu;
    const float t_cpa = v2 > 1e-6f ? std::max(-rv / v2, 0.0f) : 0.0f;
    const float mn = dn + vn * t_cpa, me = de + ve * t_cpa, mu = du + vu * t_cpa;
    f[kAdoClosing][b] = m * std::min(std::max(-rv * inv_r * (1.0f / 500.0f), -10.0f), 10.0f);
    f[kAdoTimeToClosest][b] = m * std::min(t_cpa * 0.1f, 1.0f);
    f[kAdoMissDistance][b] = m * std::min(std::sqrt(mn * mn + me * me + mu * mu) * (1.0f / 1000.0f), 10.0f);
  }
}

// ado, ado_alive: the env's rows [na, na - 1, ado_dim] and [na, na - 1]; alive: the env's [na].
// The other aircraft in agent order (self skipped), so permuting them permutes rows only.
void write_ado_rows(int na, int team_size, int ado_dim, const PackState& s, const std::uint8_t* alive, float* ado,
                    std::uint8_t* ado_alive) {
  for (int a = 0; a < na; ++a) {
    float f[kAdoSameTeam][kMaxAgents];
    ado_features(s, a, f);
    const bool a_blue = a < team_size;
    int row = 0;
    for (int b = 0; b < na; ++b) {
      if (b == a) continue;
      const std::size_t r = static_cast<std::size_t>(a) * (na - 1) + row++;
      float* d = ado + r * ado_dim;
      for (int q = 0; q < kAdoSameTeam; ++q) d[q] = f[q][b];
      d[kAdoSameTeam] = (b < team_size) == a_blue ? 1.0f : 0.0f;
      d[kAdoAlive] = s.alive_f[b];
      ado_alive[r] = alive[b];
    }
  }
}

}  // namespace

void RaceEnv::write_observations(int env) {
  const int base = env * n_agent_;
  const int na = n_agent_;
  PackState s;
  gather_pack(sim_, base, na, progress_ft_.data(), alive_.data(), &s);
  for (int a = 0; a < na; ++a) write_goal_observation(base + a);
  write_ego_rows(sim_, base, na, s, &ego_[static_cast<std::size_t>(base) * kEgoDim]);
  const std::size_t ado_row0 = static_cast<std::size_t>(base) * (na - 1);
  write_ado_rows(na, config_.team_size, ado_dim_, s, &alive_[base], &ado_[ado_row0 * ado_dim_],
                 &ado_alive_[ado_row0]);
  write_task_observations(env, s.cs[4], s.sn[4]);
}

// Track preview, every (aircraft, point) pair in two vector passes, then the task entries.
// cos_psi, sin_psi: [kMaxAgents] the env's headings.
void RaceEnv::write_task_observations(int env, const float* cos_psi, const float* sin_psi) {
  const RaceConfig& c = config_;
  const int base = env * n_agent_;
  const int na = n_agent_;
  const Track& tr = tracks_[env];
  const int np = c.preview_points;
  const int nk = na * np;
  float qn[kMaxAgents * kMaxPreview], qe[kMaxAgents * kMaxPreview], qu[kMaxAgents * kMaxPreview];
  float qr[kMaxAgents * kMaxPreview];
  tr.preview(na, np, c.preview_spacing_ft, &progress_ft_[base], sim_.state(kPn) + base, sim_.state(kPe) + base,
             sim_.state(kAlt) + base, qn, qe, qu, qr);
  const float inv_np = 1.0f / static_cast<float>(np);
  float g[4][kMaxAgents * kMaxPreview];
#pragma omp simd
  for (int k = 0; k < nk; ++k) {
    const int a = Track::preview_agent(k, inv_np);
    const float ca = cos_psi[a], sa = sin_psi[a];
    const float x = ca * qn[k] + sa * qe[k], y = -sa * qn[k] + ca * qe[k], du = qu[k];
    const float rh = std::sqrt(x * x + y * y), rr = std::sqrt(rh * rh + du * du);
    g[0][k] = std::min(rr * (1.0f / 5000.0f), 10.0f);
    g[1][k] = rh > 1e-3f ? y / rh : 0.0f;
    g[2][k] = rh > 1e-3f ? x / rh : 1.0f;
    g[3][k] = rr > 1e-3f ? du / rr : 0.0f;
  }
  for (int a = 0; a < na; ++a) {
    const int i = base + a;
    float* t = &task_[static_cast<std::size_t>(i) * task_dim_];
    for (int p = 0; p < np; ++p) {
      const int k = a * np + p;
      float* tp = t + kPreviewWidth * p;
      tp[kPreviewRange] = g[0][k];
      tp[kPreviewAzimuth] = g[1][k];
      tp[kPreviewAzimuth + 1] = g[2][k];
      tp[kPreviewSinElevation] = g[3][k];
      tp[kPreviewRadius] = qr[k] * (1.0f / 2000.0f);
    }
    float* u = t + kPreviewWidth * np;
    u[kTaskOffsets] = clampf(lateral_ft_[i] / radius_ft_[i], -10.0, 10.0);
    u[kTaskOffsets + 1] = clampf(vertical_ft_[i] / radius_ft_[i], -10.0, 10.0);
    u[kTaskCenterDistance] = clampf(dist_ft_[i] / radius_ft_[i], 0.0, 10.0);
    u[kTaskProgress] = static_cast<float>(progress_ft_[i] / tr.length_ft());
    u[kTaskTimeLeft] = static_cast<float>(1.0 - time_s_[env] / c.time_limit_s);
    u[kTaskHlTimeLeft] = static_cast<float>(std::max(hl_time_left_s_[env], 0.0) / c.dt_hl_s);
    u[kTaskEgoRank] = static_cast<float>(ego_rank_[i]) / static_cast<float>(na - 1);
    u[kTaskTeamRank] = static_cast<float>(team_rank_[i]);
  }
}

// The HL goal as the LL policy sees it: how far ahead along the track (/ goal_ahead, in [0, 10])
// and how far across it, right and up in the tube's cross-section (/ the local radius, +-10): the
// lane the high level chose, relative to the aircraft's own.
void RaceEnv::write_goal_observation(int i) {
  const double ahead = std::min(goal_progress_ft_[i], tracks_[i / n_agent_].length_ft()) - progress_ft_[i];
  float* g = &goal_obs_[static_cast<std::size_t>(i) * kGoalDim];
  g[kGoalAhead] = static_cast<float>(std::clamp(ahead / config_.goal_ahead(), 0.0, 10.0));
  double right_ft, up_ft;
  goal_lane_here(i, &right_ft, &up_ft);
  g[kGoalLaneRight] = static_cast<float>(std::clamp((right_ft - lateral_ft_[i]) / radius_ft_[i], -10.0, 10.0));
  g[kGoalLaneUp] = static_cast<float>(std::clamp((up_ft - vertical_ft_[i]) / radius_ft_[i], -10.0, 10.0));
}

void RaceEnv::copy_final_observations(int env) {
  const std::size_t a0 = static_cast<std::size_t>(env) * n_agent_, a1 = a0 + n_agent_;
  auto copy = [&](const auto& src, auto& dst, std::size_t width) {
    std::copy(src.begin() + a0 * width, src.begin() + a1 * width, dst.begin() + a0 * width);
  };
  copy(ego_, final_ego_, kEgoDim);
  copy(goal_obs_, final_goal_, kGoalDim);
  copy(prev_action_, final_prev_action_, kActionDim);
  copy(ado_, final_ado_, static_cast<std::size_t>(n_agent_ - 1) * ado_dim_);
  copy(ado_alive_, final_ado_alive_, static_cast<std::size_t>(n_agent_ - 1));
  copy(task_, final_task_, static_cast<std::size_t>(task_dim_));
}

}  // namespace f16race::race
