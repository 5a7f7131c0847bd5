// The env's exact snapshot for a resumed run: the simulator, the random streams, the tracks'
// waypoints, then every array visit_arrays lists, each with its length.
#include <istream>
#include <ostream>
#include <stdexcept>
#include <string>

#include "race/race_env.hpp"

namespace f16race::race {
namespace {

template <typename Vector>
void put_vec(std::ostream& out, const Vector& v) {
  using T = typename Vector::value_type;
  const std::int64_t n = static_cast<std::int64_t>(v.size());
  out.write(reinterpret_cast<const char*>(&n), sizeof n);
  out.write(reinterpret_cast<const char*>(v.data()), static_cast<std::streamsize>(n * sizeof(T)));
}

template <typename Vector>
void get_vec(std::istream& in, Vector* v, const char* what) {
  using T = typename Vector::value_type;
  std::int64_t n = -1;
  in.read(reinterpret_cast<char*>(&n), sizeof n);
  if (!in || n != static_cast<std::int64_t>(v->size()))
    throw std::runtime_error(std::string("race snapshot: '") + what + "' has the wrong size (another config?)");
  in.read(reinterpret_cast<char*>(v->data()), static_cast<std::streamsize>(n * sizeof(T)));
  if (!in) throw std::runtime_error(std::string("race snapshot is truncated at '") + what + "'");
}

}  // namespace

void RaceEnv::save_state(std::ostream& out) const {
  sim_.save_state(out);
  std::vector<std::uint64_t> rng(n_env());
  for (int e = 0; e < n_env(); ++e) rng[e] = rng_[e].state();
  put_vec(out, rng);
  for (int e = 0; e < n_env(); ++e) {
    std::vector<double> w;
    for (const Waypoint& p : tracks_[e].waypoints()) w.insert(w.end(), {p.p.n, p.p.e, p.p.u, p.radius_ft});
    const std::int64_t n = static_cast<std::int64_t>(w.size());
    out.write(reinterpret_cast<const char*>(&n), sizeof n);
    out.write(reinterpret_cast<const char*>(w.data()), static_cast<std::streamsize>(n * sizeof(double)));
  }
  visit_arrays(*this, [&](const char*, const auto& v, Extent, auto) { put_vec(out, v); });
}

std::vector<RaceEnv::SnapshotArray> RaceEnv::snapshot_layout() const {
  std::vector<SnapshotArray> out;
  visit_arrays(*this, [&](const char* name, const auto& v, Extent, auto) {
    out.push_back({name, v.size(), v.size() * sizeof(typename std::decay_t<decltype(v)>::value_type)});
  });
  return out;
}

void RaceEnv::load_state(std::istream& in) {
  sim_.load_state(in);
  std::vector<std::uint64_t> rng(n_env());
  get_vec(in, &rng, "random streams");
  for (int e = 0; e < n_env(); ++e) rng_[e].set_state(rng[e]);
  for (int e = 0; e < n_env(); ++e) {
    std::int64_t n = -1;
    in.read(reinterpret_cast<char*>(&n), sizeof n);
    if (!in || n < 16 || n % 4 != 0 || n > 4 * 100000) throw std::runtime_error("race snapshot: bad track record");
    std::vector<double> w(static_cast<std::size_t>(n));
    in.read(reinterpret_cast<char*>(w.data()), static_cast<std::streamsize>(n * sizeof(double)));
    if (!in) throw std::runtime_error("race snapshot is truncated in the tracks");
    std::vector<Waypoint> wp;
    for (std::int64_t k = 0; k < n; k += 4) wp.push_back({{w[k], w[k + 1], w[k + 2]}, w[k + 3]});
    tracks_[e] = Track::from_waypoints(std::move(wp), config_.track.spacing_ft);
    compute_racing_line(e);
  }
  visit_arrays(*this, [&](const char* name, auto& v, Extent, auto) { get_vec(in, &v, name); });
}

}  // namespace f16race::race
