#pragma once
// Each subcommand lives in its own file and registers itself on the CLI11 app here.
#include <stdexcept>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "io/input_error.hpp"

namespace f16race::app {

// An error the user can fix (bad flag, missing file, bad value) is an io::InputError, lib's one
// user-error type: main prints its one-line message and exits with status 2; anything else is
// reported as an internal error (status 1).

// A seed option: a non-negative integer (CLI11's NonNegativeNumber prints a 300-digit bound).
inline const CLI::Validator kNonNegativeSeed(
    [](std::string& v) { return !v.empty() && v[0] == '-' ? std::string("a seed is a non-negative integer") : std::string(); },
    "SEED >= 0");

// Ends the program with this status after a complete, orderly stop (e.g. 130 for a run
// interrupted by a signal once its checkpoint is written); main returns it without a message.
struct ExitStatus {
  int code;
};

void add_simulate_command(CLI::App& app);
void add_bench_command(CLI::App& app, const int& threads_option);
void add_race_command(CLI::App& app);
void add_train_command(CLI::App& app);
void add_tournament_command(CLI::App& app);
void add_export_command(CLI::App& app);
void add_replay_command(CLI::App& app);
void add_study_command(CLI::App& app);
// `threads_option`: main's --threads (0: not given), read when the command runs.
void add_launch_command(CLI::App& app, const int& threads_option);
// Starts `nproc` ranks of `command` (a subcommand and its arguments) on loopback and waits for
// them (apps/f16race/cmd_launch.cpp); threads per rank: `threads`, or the cores' share if 0.
// Throws ExitStatus with the first failing rank's status.
void launch_ranks(int nproc, const std::vector<std::string>& command, int threads, double timeout_s, int port = 0);
// Registered on the `bench` group by add_bench_command (apps/f16race/bench_nets.cpp).
void add_bench_nets_command(CLI::App& bench);
void add_bench_train_command(CLI::App& bench, const int& threads_option);

}  // namespace f16race::app
