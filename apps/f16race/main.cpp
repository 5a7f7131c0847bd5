// f16race: batched F-16 team racing, from the flight model to trained policies.
#include <dlfcn.h>
#include <malloc.h>
#include <omp.h>

#include <strings.h>
#include <unistd.h>

#include <ATen/Context.h>
#include <ATen/Version.h>
#include <CLI/CLI.hpp>
#include <c10/util/Exception.h>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <exception>
#include <new>
#include <string>

#include "commands.hpp"
#include "dist/process_group.hpp"
#include "io/input_error.hpp"
#include "io/numeric_mode.hpp"
#include "io/openmp_waits.hpp"
#include "io/provenance.hpp"

// OpenBLAS (LibTorch's BLAS on Debian) runs its own thread pool that spins against the
// OpenMP threads of the simulator and of LibTorch; measured 2.7x slower training. Parallelism
// comes from OpenMP alone, so OpenBLAS is held to one thread when it is the BLAS in use.
static void single_threaded_blas() {
  using SetThreads = void (*)(int);
  if (auto f = reinterpret_cast<SetThreads>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"))) f(1);
}

// The binary's own path, not /proc/self/exe, so that ps and top still show "f16race"; "" without /proc.
static std::string own_path() {
  char self[4096];
  const ssize_t n = readlink("/proc/self/exe", self, sizeof self - 1);
  if (n <= 0) return std::string();
  self[n] = '\0';
  return self;
}

// The reproducible build's kernels use AVX2 and FMA: on an older CPU say so, before any static
// initializer of those kernels could stop on an illegal instruction.
__attribute__((constructor(101))) static void cpu_runs_this_build() {
  if (f16race::io::numeric_mode() != f16race::io::NumericMode::kReproducible) return;
  __builtin_cpu_init();
  if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) return;
  std::fprintf(stderr, "f16race: error: this CPU lacks AVX2 or FMA, which the reproducible build needs (x86-64-v3: Intel "
                       "since Haswell, AMD since Zen 1); build for it with F16RACE_ARCH=native scripts/build.sh\n");
  std::_Exit(2);
}

// The environment the libraries read when they load, before main: OpenBLAS its kernel set, glibc
// its tunables, libgomp its spin count. When main changes it, the process runs itself again, once
// (~0.4 s). A reproducible build that cannot is refused; a native one goes on as it was loaded.
static void run_itself_again(char** argv) {
  const std::string self = own_path();
  if (!self.empty()) execv(self.c_str(), argv);
  if (f16race::io::numeric_mode() != f16race::io::NumericMode::kReproducible) return;
  std::fprintf(stderr, "f16race: error: could not run itself again with its kernel choices pinned (%s); run it "
                       "with OPENBLAS_CORETYPE=Haswell ATEN_CPU_CAPABILITY=avx2 set, or build with F16RACE_ARCH=native\n",
               self.empty() ? "no /proc/self/exe" : std::strerror(errno));
  std::exit(2);
}

// Reproducible mode: the environment every library reads its kernel choice from is pinned
// (io/numeric_mode.hpp) before this runs; here the choices are checked, so that a run never
// silently trains with other kernels.
static void check_reproducible_kernels() {
  const std::string core = f16race::io::blas_core();
  if (strcasecmp(core.c_str(), "haswell") != 0) {
    std::fprintf(stderr, "f16race: error: the reproducible build needs OpenBLAS's Haswell kernels as LibTorch's BLAS, and "
                         "%s; select Debian's OpenBLAS (update-alternatives --config libblas.so.3-x86_64-linux-gnu; "
                         "scripts/setup.sh installs libopenblas0-pthread) or build with F16RACE_ARCH=native\n",
                 core.empty() ? "libblas.so.3 is not OpenBLAS" : ("OpenBLAS runs its " + core + " set").c_str());
    std::exit(2);
  }
  // LibTorch 1.13 exports no query of its capability but this line of its build summary.
  if (at::show_config().find("CPU capability usage: AVX2\n") == std::string::npos) {
    std::fprintf(stderr, "f16race: error: LibTorch did not take its avx2 kernels (ATEN_CPU_CAPABILITY=avx2); build with "
                         "F16RACE_ARCH=native\n");
    std::exit(2);
  }
  // oneDNN is not on any path the networks take today; off, it cannot become one.
  at::globalContext().setUserEnabledMkldnn(false);
}

// Native mode: OpenBLAS picks its kernels from the CPU model when it loads, and takes its pre-AVX
// "Prescott" set for a model it does not know (0.3.21 on Intel family 6 model 207): every LibTorch
// GEMM then ran ~3x slower (bench nets, 1024^3 float product, 2 threads: 30 against 97 GFLOP/s with
// the SkylakeX set). Only OPENBLAS_CORETYPE, read at load time, overrides that choice, so it is set
// from the CPU's features (true: set). A user's OPENBLAS_CORETYPE is left as it is.
static bool choose_known_blas_kernels() {
  if (std::getenv("OPENBLAS_CORETYPE") != nullptr) return false;
  if (strcasecmp(f16race::io::blas_core().c_str(), "prescott") != 0) return false;
  __builtin_cpu_init();
  const char* core = nullptr;
  if (__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512dq") &&
      __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512cd"))
    core = "SkylakeX";
  else if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"))
    core = "Haswell";
  else if (__builtin_cpu_supports("avx"))
    core = "Sandybridge";
  if (core == nullptr) return false;  // Prescott is the right set for this CPU
  return setenv("OPENBLAS_CORETYPE", core, 1) == 0;
}

// LibTorch allocates and frees the same large activation and gradient buffers on every PPO
// minibatch and rollout step. glibc returns blocks above its mmap threshold (and the heap top
// above the trim threshold) to the kernel at every free, so each step paid page faults and page
// clearing again (~8 % of a training profile in the kernel). Keep freed memory in the process:
// mmap only for blocks above 32 MiB (glibc's maximum), never trim below 1 GiB of free heap.
static void keep_freed_memory() {
  mallopt(M_MMAP_THRESHOLD, 32 * 1024 * 1024);
  mallopt(M_TRIM_THRESHOLD, 1024 * 1024 * 1024);
  mallopt(M_TOP_PAD, 64 * 1024 * 1024);
}

// Every numeric option of every subcommand refuses an empty value (`--seed "$UNSET"` converted
// silently to 0), and every floating-point one nan and infinities (and numbers that overflow a
// double): CLI11's Range lets nan through (every comparison with it is false), and no option
// means one. Added here, after the commands defined theirs, so none can be missed; the message
// names the option (CLI11 prefixes it).
static void numbers_only(CLI::App* app) {
  static const CLI::Validator number(
      [](std::string& text) {
        if (text.empty()) return std::string("an empty value; give a number");
        return std::string();
      },
      "");
  static const CLI::Validator finite(
      [](std::string& text) {
        const char* begin = text.c_str();
        char* end = nullptr;
        const double v = std::strtod(begin, &end);
        if (end == begin || *end != '\0') return std::string();  // not a number: the conversion says so
        return std::isfinite(v) ? std::string() : "'" + text + "' is not a finite number; give one such as 0.5 or 1e3";
      },
      "");
  for (CLI::Option* opt : app->get_options()) {
    if (opt->get_type_size() == 0) continue;  // a flag
    const std::string type = opt->get_type_name();
    const bool is_float = type.rfind("FLOAT", 0) == 0;
    if (is_float || type.rfind("INT", 0) == 0 || type.rfind("UINT", 0) == 0) opt->check(number);
    if (is_float) opt->check(finite);
  }
  for (CLI::App* sub : app->get_subcommands([](CLI::App*) { return true; })) numbers_only(sub);
}

static std::string subcommand_names(const CLI::App& app) {
  std::string names;
  for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; }))
    names += (names.empty() ? "" : ", ") + sub->get_name();
  return names;
}

// The first word where a subcommand belongs, when no subcommand was parsed and it names none:
// CLI11 reports that only as "A subcommand is required", without the word.
static std::string unknown_subcommand(const CLI::App& app, int argc, char** argv) {
  if (!app.get_subcommands().empty()) return "";
  for (int k = 1; k < argc; ++k) {
    const std::string a = argv[k];
    if (a == "--threads") {
      ++k;  // its value
      continue;
    }
    if (a.empty() || a[0] == '-') continue;
    for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; }))
      if (sub->check_name(a)) return "";
    return a;
  }
  return "";
}

static int out_of_memory() {
  std::fprintf(stderr, "f16race: error: out of memory: the workload does not fit in this machine's memory; make it "
                       "smaller (race.n_env, race.team_size, ll.n_steps, network sizes, --races, --aircraft, ...)\n");
  return 2;
}

int main(int argc, char** argv) {
  const bool reproducible = f16race::io::numeric_mode() == f16race::io::NumericMode::kReproducible;
  bool environment_changed = f16race::io::bound_openmp_spins();
  environment_changed |= reproducible ? f16race::io::pin_numeric_environment() : choose_known_blas_kernels();
  if (environment_changed) run_itself_again(argv);
  if (reproducible) check_reproducible_kernels();
  keep_freed_memory();
  single_threaded_blas();
  CLI::App app{"f16race: simulate, race, train and evaluate teams of F-16 aircraft (AeroBench dynamics)"};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("f16race 0.1.0, commit ") + f16race::io::build_commit() +
                                        "\nnumerics: " + f16race::io::numeric_mode_summary());
  int threads = 0;
  // Bounded by the machine: more threads than 4 x its cores only spin against each other (OpenMP
  // waits actively), which made a large count look like a hang.
  const int max_threads = 4 * std::max(1, omp_get_num_procs());
  app.add_option("--threads", threads,
                 "OpenMP threads for the simulator (0 = all cores, at most 4 x cores = " + std::to_string(max_threads) + ")")
      ->check(CLI::Range(0, max_threads));
  // Thread count is set once, before any parallel region; subcommands never change it
  // (except `bench`, which measures 1 thread and all threads on purpose).
  app.parse_complete_callback([&]() {
    if (threads > 0) omp_set_num_threads(threads);
  });
  f16race::app::add_simulate_command(app);
  f16race::app::add_train_command(app);
  f16race::app::add_tournament_command(app);
  f16race::app::add_export_command(app);
  f16race::app::add_replay_command(app);
  f16race::app::add_study_command(app);
  f16race::app::add_race_command(app);
  f16race::app::add_bench_command(app, threads);
  f16race::app::add_launch_command(app, threads);
  numbers_only(&app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (const std::string word = unknown_subcommand(app, argc, argv); !word.empty()) {
      std::fprintf(stderr, "f16race: error: '%s' is not a subcommand; give one of %s (f16race --help)\n", word.c_str(),
                   subcommand_names(app).c_str());
      return 2;
    }
    // --help and --version are "errors" with code 0; real parse errors exit 2 like bad input.
    const int rc = app.exit(e);
    return rc == 0 ? 0 : 2;
  } catch (const f16race::app::ExitStatus& e) {
    return e.code;
  } catch (const f16race::io::InputError& e) {  // every user error: config, CSV, run folder, disk, option
    std::fprintf(stderr, "f16race: error: %s\n", e.what());
    return 2;
  } catch (const f16race::dist::PeerLost& e) {  // another rank of the group stopped: not this one's fault
    std::fprintf(stderr, "f16race: error: %s\n", e.what());
    return 3;
  } catch (const std::filesystem::filesystem_error& e) {
    std::fprintf(stderr, "f16race: error: %s\n", e.what());
    return 2;
  } catch (const std::bad_alloc&) {  // a workload larger than the machine: the user's to size, not a bug
    return out_of_memory();
  } catch (const c10::Error& e) {  // LibTorch's allocator says the same in its own words
    if (std::strstr(e.what_without_backtrace(), "can't allocate memory") != nullptr) return out_of_memory();
    std::fprintf(stderr, "f16race: internal error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "f16race: internal error: %s\n", e.what());
    return 1;
  }
  return 0;
}
