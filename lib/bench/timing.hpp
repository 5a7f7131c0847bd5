#pragma once
// Medians of repeated timings: every speed figure of `f16race bench` is one.
#include <functional>
#include <vector>

namespace f16race::bench {

double median_of(std::vector<double> v);
// Median seconds of `f` over `repeats` timed runs after one warm-up run.
double time_median_s(const std::function<void()>& f, int repeats);

}  // namespace f16race::bench
