// Issue 18's test (a) over real ranks: run as rank RANK of WORLD_SIZE = 2 on loopback (the
// variables launch sets). Each rank updates a PPO agent and an ES agent of every variant on its
// share of one sample set through dist::Group; rank 0 also updates one agent on all the samples
// alone, and the ranks' weights must equal it to float summation order (and each other, bit for
// bit). Exit 0 when they do, 1 with the differences otherwise. The same check with threads as
// ranks: tests/agents/test_replicas.cpp.
#include <torch/torch.h>

#include <cstdint>
#include <cstdio>
#include <string>

#include "dist/process_group.hpp"
#include "support/replica_samples.hpp"

using namespace f16race;
using namespace f16race::test_support;

namespace {

std::uint64_t bits_hash(torch::nn::Module& m) {
  std::uint64_t h = 1469598103934665603ULL;
  for (const auto& p : m.parameters()) {
    const auto c = p.detach().contiguous();
    const auto* b = static_cast<const unsigned char*>(c.data_ptr());
    for (std::size_t i = 0; i < static_cast<std::size_t>(c.nbytes()); ++i) h = (h ^ b[i]) * 1099511628211ULL;
  }
  return h;
}

// The ranks' weights are the same bits: their hashes, all-gathered as two exact halves.
bool ranks_agree(dist::Group& g, torch::nn::Module& m) {
  const std::uint64_t h = bits_hash(m);
  const auto all = g.allgather({static_cast<double>(h >> 32), static_cast<double>(h & 0xFFFFFFFFULL)});
  for (int r = 1; r < g.size(); ++r)
    if (all[2 * r] != all[0] || all[2 * r + 1] != all[1]) return false;
  return true;
}

}  // namespace

int main() {
  torch::set_num_threads(1);
  const dist::DistConfig dc = dist::dist_config_from_environment();
  if (dc.world_size != 2) {
    std::fprintf(stderr, "replicas_over_gloo: run as 2 ranks (WORLD_SIZE=2, RANK=0/1)\n");
    return 2;
  }
  dist::Group group(dc, "replicas_over_gloo");
  agents::Replicas replicas;
  replicas.sum_floats = [&group](float* v, std::int64_t n) { group.allreduce_sum(v, static_cast<std::size_t>(n)); };
  replicas.sum_doubles = [&group](double* v, std::int64_t n) { group.allreduce_sum(v, static_cast<std::size_t>(n)); };
  replicas.gather = [&group](const std::vector<double>& v) { return group.allgather(v); };
  const int r = group.rank();
  bool ok = true;

  const models::ObsDims ll_dims{4, 2, 3, 2};
  const agents::PpoConfig ppo_cfg = replica_ppo_config(ll_dims);
  const PpoSamples samples = ppo_samples(ll_dims);
  const int64_t cut[3] = {0, 6, 10};
  torch::manual_seed(4);
  PpoAgent replica(ppo_cfg);
  replica.set_replicas(replicas);
  ppo_update_on(replica, samples, cut[r], cut[r + 1]);
  if (!ranks_agree(group, *replica.net())) ok = false, std::printf("rank %d: PPO replicas differ between ranks\n", r);
  if (r == 0) {
    // One process with all the aircraft, as a group of one (statistics held back over the
    // rollout, as a group's are).
    agents::Replicas solo;
    solo.sum_floats = [](float*, std::int64_t) {};
    solo.sum_doubles = [](double*, std::int64_t) {};
    solo.gather = [](const std::vector<double>& v) { return v; };
    torch::manual_seed(4);
    PpoAgent one(ppo_cfg);
    one.set_replicas(solo);
    ppo_update_on(one, samples, 0, 10);
    const double d = max_abs_diff(*one.net(), *replica.net());
    std::printf("PPO: 2 ranks (6 + 4 aircraft) vs one process (10): max |weight difference| %.3g\n", d);
    if (!(d < 2e-5)) ok = false;
  }

  const models::ObsDims hl_dims{4, 2, 2, 2};
  const int64_t teams[3] = {0, 5, 8};
  for (agents::EsVariant v : {agents::EsVariant::kEs, agents::EsVariant::kEsD1, agents::EsVariant::kEsD2,
                              agents::EsVariant::kEsD3}) {
    const agents::EsConfig es_cfg = replica_es_config(v, hl_dims);
    torch::manual_seed(6);
    agents::EsAgent es(es_cfg);
    es.set_replicas(replicas);
    es.update(es_batch(hl_dims, teams[r], teams[r + 1]));
    if (!ranks_agree(group, *es.critic()))
      ok = false, std::printf("rank %d: %s replicas differ between ranks\n", r, agents::es_variant_name(v));
    if (r == 0) {
      torch::manual_seed(6);
      agents::EsAgent one(es_cfg);
      one.update(es_batch(hl_dims, 0, 8));
      const double d = max_abs_diff(*one.critic(), *es.critic());
      std::printf("%s: 2 ranks (5 + 3 teams) vs one process (8): max |weight difference| %.3g\n",
                  agents::es_variant_name(v), d);
      if (!(d < 2e-5)) ok = false;
    }
  }
  std::vector<std::int64_t> failures{ok ? 0 : 1};
  group.allreduce_sum(failures);
  if (r == 0) std::printf("%s\n", failures[0] == 0 ? "OK" : "FAIL");
  return failures[0] == 0 ? 0 : 1;
}
