// Data-parallel replicas (issue 18, agents/replicas.hpp): the equivalence that holds exactly is
// that an update of two replicas, each on its share of the samples, equals one process's update
// on the union of the samples (to float summation order). Full-batch steps (one minibatch per
// epoch) make the union well defined; the two replicas run on two threads that meet in a
// stand-in for the group's collectives. dist_train.sh runs the same code over Gloo.
#include <gtest/gtest.h>
#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <condition_variable>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "agents/expected_sarsa.hpp"
#include "agents/ppo.hpp"
#include "agents/replicas.hpp"
#include "support/replica_samples.hpp"

namespace f16race::agents {
namespace {

using namespace test_support;

// n threads standing in for n ranks: each exchange returns every rank's vector in rank order.
class ThreadGroup {
 public:
  explicit ThreadGroup(int n) : n_(n), slots_(static_cast<std::size_t>(n)) {}
  std::vector<double> exchange(int rank, const std::vector<double>& mine) {
    std::unique_lock<std::mutex> lock(mutex_);
    slots_[static_cast<std::size_t>(rank)] = mine;
    const long generation = generation_;
    if (++arrived_ == n_) {
      result_.clear();
      for (const auto& s : slots_) result_.insert(result_.end(), s.begin(), s.end());
      arrived_ = 0;
      ++generation_;
      ++exchanges_;
      done_.notify_all();
    } else {
      done_.wait(lock, [&] { return generation_ != generation; });
    }
    return result_;
  }
  Replicas replicas(int rank) {
    Replicas r;
    r.sum_doubles = [this, rank](double* v, std::int64_t k) { sum(rank, v, k); };
    r.sum_floats = [this, rank](float* v, std::int64_t k) {
      std::vector<double> d(v, v + k);
      const std::vector<double> all = exchange(rank, d);
      for (std::int64_t i = 0; i < k; ++i) {
        float s = 0.0f;  // float sums in rank order, as Gloo's
        for (int q = 0; q < n_; ++q) s += static_cast<float>(all[static_cast<std::size_t>(q * k + i)]);
        v[i] = s;
      }
    };
    r.gather = [this, rank](const std::vector<double>& v) { return exchange(rank, v); };
    return r;
  }
  long exchanges() const { return exchanges_; }

 private:
  void sum(int rank, double* v, std::int64_t k) {
    const std::vector<double> all = exchange(rank, std::vector<double>(v, v + k));
    for (std::int64_t i = 0; i < k; ++i) {
      double s = 0.0;
      for (int q = 0; q < n_; ++q) s += all[static_cast<std::size_t>(q * k + i)];
      v[i] = s;
    }
  }
  int n_;
  std::mutex mutex_;
  std::condition_variable done_;
  std::vector<std::vector<double>> slots_;
  std::vector<double> result_;
  int arrived_ = 0;
  long generation_ = 0, exchanges_ = 0;
};

// Two replicas of an agent (the same initial weights: torch seeded with `seed` before each), each
// running work(agent, rank) on its own thread, meeting through a ThreadGroup.
template <class Agent, class Config, class Work>
std::vector<std::unique_ptr<Agent>> two_replicas(const Config& cfg, uint64_t seed, const Work& work) {
  std::vector<std::unique_ptr<Agent>> ranks;
  for (int r = 0; r < 2; ++r) {
    torch::manual_seed(seed);
    ranks.push_back(std::make_unique<Agent>(cfg));
  }
  ThreadGroup group(2);
  std::vector<std::thread> threads;
  for (int r = 0; r < 2; ++r)
    threads.emplace_back([&, r] {
      Agent& agent = *ranks[static_cast<std::size_t>(r)];
      agent.set_replicas(group.replicas(r));
      work(agent, r);
    });
  for (auto& t : threads) t.join();
  return ranks;
}

TEST(Replicas, TwoPpoReplicasTakeTheUnionsSteps) {
  models::ObsDims dims{4, 2, 3, 2};
  const PpoConfig cfg = replica_ppo_config(dims);
  const PpoSamples samples = ppo_samples(dims);

  // The reference: one process with all ten aircraft, as a group of one (whose observation
  // statistics are held back over the rollout as a group's are; see
  // APpoReplicaWithoutValidRowsStillTakesPart for a plain agent).
  ThreadGroup solo(1);
  torch::manual_seed(4);
  PpoAgent one(cfg);
  one.set_replicas(solo.replicas(0));
  const PpoStats one_stats = ppo_update_on(one, samples, 0, 10);

  std::vector<PpoStats> stats(2);
  const int64_t cut[3] = {0, 6, 10};
  const auto ranks = two_replicas<PpoAgent>(cfg, 4, [&](PpoAgent& agent, int r) {
    stats[static_cast<std::size_t>(r)] = ppo_update_on(agent, samples, cut[r], cut[r + 1]);
  });

  // The replicas are the same bits, and they equal the one process to float summation order
  // (Adam at lr 1e-2 moves a weight ~1e-2 per step: a wrong gradient moves it that much).
  EXPECT_TRUE(same_bits(*ranks[0]->net(), *ranks[1]->net()));
  const double d = max_abs_diff(*one.net(), *ranks[0]->net());
  EXPECT_LT(d, 2e-5);
  torch::manual_seed(4);
  PpoAgent initial(cfg);
  EXPECT_GT(max_abs_diff(*one.net(), *initial.net()), 1e-3);  // the update did move the weights
  // Observation statistics absorbed the union: equal to one process's to rounding; they moved.
  EXPECT_NEAR(one.normalizer()->ego()->count(), 6 * 10 + 1e-4, 1e-9);
  EXPECT_NEAR(ranks[1]->normalizer()->ego()->count(), one.normalizer()->ego()->count(), 1e-9);
  EXPECT_LT((ranks[1]->normalizer()->ego()->mean() - one.normalizer()->ego()->mean()).abs().max().item<double>(), 1e-12);
  EXPECT_LT((ranks[0]->normalizer()->ado()->var() - one.normalizer()->ado()->var()).abs().max().item<double>(), 1e-12);
  // The reported losses are the union's on both ranks.
  EXPECT_NEAR(stats[0].policy_loss, one_stats.policy_loss, 1e-5);
  EXPECT_NEAR(stats[1].value_loss, one_stats.value_loss, 1e-4);
  EXPECT_EQ(stats[0].grad_steps, one_stats.grad_steps);
  // Rank 0 sees 6 of 10 rows: its share is not the union's, so a missing reduction would fail above.
  EXPECT_NE(stats[0].train_rows, one_stats.train_rows);
}

TEST(Replicas, APpoReplicaWithoutValidRowsStillTakesPart) {
  // Rank 1's aircraft all dead this rollout: the group steps on rank 0's rows alone. (Without
  // observation statistics, which take every row, the dead ones' too.)
  models::ObsDims dims{4, 2, 3, 2};
  PpoConfig cfg = replica_ppo_config(dims);
  cfg.normalize_obs = false;
  cfg.n_minibatches = 2;  // rank 0's minibatches are `alone`'s
  cfg.learning_rate = 3e-4;
  PpoSamples samples = ppo_samples(dims);
  for (auto& v : samples.valid) v.slice(0, 6, 10).fill_(false);
  torch::manual_seed(4);
  PpoAgent alone(cfg);
  ppo_update_on(alone, samples, 0, 6);
  const int64_t cut[3] = {0, 6, 10};
  const auto ranks = two_replicas<PpoAgent>(
      cfg, 4, [&](PpoAgent& agent, int r) { ppo_update_on(agent, samples, cut[r], cut[r + 1]); });
  EXPECT_TRUE(same_bits(*ranks[0]->net(), *ranks[1]->net()));
  // Minibatch order is rank 0's own draw, as `alone`'s: the very steps, to float rounding.
  EXPECT_LT(max_abs_diff(*alone.net(), *ranks[1]->net()), 1e-5);
}

TEST(Replicas, TwoEsReplicasTakeTheUnionsStepsForEveryVariant) {
  models::ObsDims dims{4, 2, 2, 2};
  for (EsVariant v : {EsVariant::kEs, EsVariant::kEsD1, EsVariant::kEsD2, EsVariant::kEsD3}) {
    const EsConfig cfg = replica_es_config(v, dims);
    torch::manual_seed(6);
    EsAgent one(cfg);
    const EsStats one_stats = one.update(es_batch(dims, 0, 8));
    std::vector<EsStats> stats(2);
    const int64_t cut[3] = {0, 5, 8};
    const auto ranks = two_replicas<EsAgent>(cfg, 6, [&](EsAgent& agent, int r) {
      stats[static_cast<std::size_t>(r)] = agent.update(es_batch(dims, cut[r], cut[r + 1]));
    });
    EXPECT_TRUE(same_bits(*ranks[0]->critic(), *ranks[1]->critic())) << es_variant_name(v);
    EXPECT_LT(max_abs_diff(*one.critic(), *ranks[1]->critic()), 2e-5) << es_variant_name(v);
    EXPECT_NEAR(stats[0].loss, one_stats.loss, 1e-5 * std::max(1.0, std::abs(one_stats.loss))) << es_variant_name(v);
    EXPECT_NEAR(ranks[1]->normalizer()->task()->count(), one.normalizer()->task()->count(), 1e-9);
    // A replica whose batch is empty this time still takes every step with the others.
    const int64_t all_or_none[3] = {0, 8, 8};
    const auto pair = two_replicas<EsAgent>(
        cfg, 6, [&](EsAgent& agent, int r) { agent.update(es_batch(dims, all_or_none[r], all_or_none[r + 1])); });
    EXPECT_TRUE(same_bits(*pair[0]->critic(), *pair[1]->critic())) << es_variant_name(v);
    EXPECT_LT(max_abs_diff(*one.critic(), *pair[1]->critic()), 2e-5) << es_variant_name(v);
  }
}

}  // namespace
}  // namespace f16race::agents
