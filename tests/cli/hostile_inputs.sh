#!/usr/bin/env bash
# Issue 15's hostile user, as a test: every case must end within 60 s with exit status 2, a short
# message on stderr (at most 3 lines) that names the key, option or file at fault where the case
# gives one, no "internal error", no C++ or LibTorch backtrace, and leave the trained run it may
# touch unchanged. Inputs that must be read (a byte-order mark, Windows line ends) must succeed.
# Usage: hostile_inputs.sh F16RACE_BINARY CONFIG_DIR WORK_DIR
set -uo pipefail
bin=$1 configs=$2 work=$3
rm -rf "$work" && mkdir -p "$work"
cd "$work"
smoke="$configs/smoke.yaml"
run="$work/run"
"$bin" train --config "$smoke" --run "$run" --max-updates 2 --quiet >/dev/null || { echo "FAIL: setup run"; exit 1; }
snapshot() { (cd "$run" && find . -type f ! -name .lock -exec md5sum {} + | sort); }
before=$(snapshot)
# Inputs.
printf 'race:\n  n_env: [1\n' > bad_syntax.yaml
printf 'race:\n  n_env: 6\n  n_env: 4\n' > duplicate.yaml
printf 'seed: 1\nrace: 5\n' > not_mapping.yaml
printf 'seed: 1\nrace: ~\n' > empty_section.yaml
printf '\x00\x01\x02binary' > binary.yaml
printf 't_s,Nz_ref_g\n' > header_only.csv
printf 't_s,Nz_ref_g\n0,1\n0,2\n' > not_increasing.csv
printf 't_s,Nz_ref_g\n0,abc\n' > not_number.csv
printf 't_s,vt\n0,1,2\n' > ragged.csv
mkdir -p not_a_run && echo "x" > not_a_run/file
cp -r "$run" corrupt_latest && echo "step_9999999999_u1" > corrupt_latest/checkpoint/LATEST && rm -f corrupt_latest/.lock
cp -r "$run" truncated && rm -f truncated/.lock
ck=$(cat truncated/checkpoint/LATEST)
truncate -s 100 "truncated/checkpoint/$ck/trainer.pt"
fails=0 n=0
case_() {  # case_ DESCRIPTION [NAMED] -- COMMAND...: the message must contain NAMED (the key, option or file)
  local desc=$1 named=""
  shift
  if [ "$1" != "--" ]; then named=$1; shift; fi
  shift
  n=$((n + 1))
  # A refused command leaves no output folder of its own behind (an existing one it must not touch).
  local target="" prev="" a
  for a in "$@"; do [ "$prev" = "--out" ] && target=$a; prev=$a; done
  local fresh=0
  [ -n "$target" ] && [ ! -e "$target" ] && fresh=1
  local out rc
  out=$(timeout 60 "$@" 2>&1 >/dev/null)
  rc=$?
  local lines
  lines=$(printf '%s\n' "$out" | grep -c .)
  if [ "$rc" -ne 2 ] || [ "$lines" -gt 3 ] || [[ "$out" == *"internal error"* ]] || [[ "$out" == *"Exception raised from"* ]] ||
     [[ "$out" == *"terminate called"* ]] || [[ "$out" != *"$named"* ]]; then
    echo "FAIL [$desc]: rc $rc, $lines lines${named:+, must name '$named'}: $out"
    fails=$((fails + 1))
  elif [ "$fresh" = 1 ] && [ -e "$target" ]; then
    echo "FAIL [$desc]: refused, but left its --out $target behind"
    fails=$((fails + 1))
  fi
}
accepted_() {  # accepted_ DESCRIPTION -- COMMAND...: an input that must be read (exit 0, no message)
  local desc=$1
  shift 2
  n=$((n + 1))
  local out rc
  out=$(timeout 60 "$@" 2>&1 >/dev/null)
  rc=$?
  if [ "$rc" -ne 0 ] || [ -n "$out" ]; then
    echo "FAIL [$desc]: rc $rc (must be read): $out"
    fails=$((fails + 1))
  fi
}
T="$bin train --config $smoke --run $work/new"
case_ "config missing" nope.yaml -- "$bin" train --config nope.yaml --run "$work/n1"
case_ "config is a folder" "$work: is a directory" -- "$bin" train --config "$work" --run "$work/n2"
case_ "config is a device" /dev/zero -- "$bin" train --config /dev/zero --run "$work/n3"
case_ "config is binary" binary.yaml -- "$bin" train --config binary.yaml --run "$work/n4"
case_ "YAML syntax" bad_syntax.yaml:3 -- "$bin" train --config bad_syntax.yaml --run "$work/n5"
case_ "duplicate key" "duplicate.yaml:3: race.n_env" -- "$bin" train --config duplicate.yaml --run "$work/n6"
case_ "section not a mapping" "not_mapping.yaml: 'race'" -- "$bin" train --config not_mapping.yaml --run "$work/n7"
case_ "empty section" "empty_section.yaml:2: race is an empty section" -- "$bin" train --config empty_section.yaml --run "$work/n7"
case_ "unknown subcommand" "'bogus' is not a subcommand" -- "$bin" --threads 1 bogus --races 2
case_ "unknown key" "unknown key 'foo'" -- $T --set foo=1
case_ "n_env 0" "race.n_env: value 0" -- $T --set race.n_env=0
case_ "n_env text" "race.n_env: expected an integer, got 'abc'" -- $T --set race.n_env=abc
case_ "team_size 9" "race.team_size: value 9" -- $T --set race.team_size=9
case_ "dt_ll 0" "race.dt_ll_s: value 0" -- $T --set race.dt_ll_s=0
case_ "dt_hl tiny" "race.dt_hl_s: value 0.01" -- $T --set race.dt_hl_s=0.01
case_ "dt_hl > time limit" "dt_hl_s (8) must be <= time_limit_s (5)" -- $T --set race.time_limit_s=5 --set race.dt_hl_s=8
case_ "legs crossed" "track.leg_min_ft (9000) must be <= track.leg_max_ft (8000)" -- $T --set race.track.leg_min_ft=9000
case_ "radii crossed" "track.radius_min_ft (2000)" -- $T --set race.track.radius_min_ft=2000
case_ "unknown model" "race.model: 'jsbsim'" -- $T --set race.model=jsbsim
case_ "unknown tube exit" "race.tube_exit" -- $T --set race.tube_exit=maybe
case_ "unknown goal frame" "race.goal_frame" -- $T --set race.goal_frame=polar
case_ "unknown agent" "hl.agent: 'es_d4'" -- $T --set hl.agent=es_d4
case_ "epsilon 1.5" "hl.epsilon: value 1.5" -- $T --set hl.epsilon=1.5
case_ "support crossed" "hl.v_min must be < hl.v_max (or both 0: derived from the race); got 5 and 1" -- $T --set hl.v_min=5 --set hl.v_max=1
case_ "one atom" "hl.n_atoms: value 1" -- $T --set hl.n_atoms=1
# Issue 51's retired switches: at another value than this build behaves as, one line naming the
# key, the value and the commit to build.
case_ "retired per-axis critic" "hl.critic: per_axis was removed" -- $T --set hl.critic=per_axis
case_ "retired per-axis target" "hl.team_target: per_axis was removed" -- $T --set hl.team_target=per_axis
case_ "retired team lane" "hl.lateral: team was removed" -- $T --set hl.lateral=team
case_ "retired team exploration" "hl.explore: team was removed" -- $T --set hl.explore=team
case_ "retired team explore scale" "hl.team_explore_scale: 0.25 was removed" -- $T --set hl.team_explore_scale=0.25
case_ "retired lane origin" "race.goal_origin: lane was removed" -- $T --set race.goal_origin=lane
case_ "retired team lanes" "race.observe_team_lanes: true was removed" -- $T --set race.observe_team_lanes=true
case_ "retired center share" "pool.p_center: 0.25 was removed" -- $T --set pool.p_center=0.25
case_ "retired weight average" "train.hl_average_share: 0.2 was removed" -- $T --set train.hl_tail_share=0.3 --set train.hl_average_share=0.2
case_ "retired inference switch" "hl.inference: torch was removed" -- $T --set hl.inference=torch
case_ "race seed other than seed" "race.seed = 5 differs from seed = 3" -- $T --set race.seed=5
case_ "empty hidden" "ll.hidden" -- $T --set "ll.hidden=[]"
case_ "zero hidden" "ll.hidden: element 0 = 0" -- $T --set "ll.hidden=[0]"
case_ "negative lr" "ll.learning_rate: value -1" -- $T --set ll.learning_rate=-1
case_ "negative steps" "train.total_env_steps" -- $T --set train.total_env_steps=-5
case_ "p_self_play 2" "pool.p_self_play: value 2" -- $T --set pool.p_self_play=2
case_ "center share in the tail without a tail" "pool.p_center_tail" -- $T --set pool.p_center_tail=0.25
case_ "center share in the tail 1.5" "pool.p_center_tail: value 1.5" -- $T --set train.hl_tail_share=0.3 --set pool.p_center_tail=1.5
case_ "tail member in a user config" "train.tail_member = 1 is written by train" -- $T --set train.hl_tail_share=0.3 --set train.tail_member=1
case_ "tail members without a tail" "train.hl_tail_members = 3" -- $T --set train.hl_tail_members=3
case_ "tail members 17" "train.hl_tail_members: value 17" -- $T --set train.hl_tail_share=0.3 --set train.hl_tail_members=17
case_ "--set without =" "--set 'race.n_env'" -- $T --set race.n_env
case_ "--set empty key" "race..n_env" -- $T --set race..n_env=3
case_ "--set bad YAML" "race.n_env=[1" -- $T --set "race.n_env=[1"
case_ "negative seed" --seed -- $T --seed -4
case_ "unknown agent flag" --agent -- $T --agent es_d9
case_ "resume missing" -- "$bin" train --resume "$work/nothing"
case_ "resume with --seed" -- "$bin" train --resume "$run" --seed 3
case_ "fresh run over a run" -- "$bin" train --config "$smoke" --run "$run"
case_ "resume not a run" -- "$bin" train --resume not_a_run
case_ "resume corrupt LATEST" -- "$bin" train --resume corrupt_latest
case_ "resume truncated checkpoint" -- "$bin" train --resume truncated
case_ "threads huge" --threads -- "$bin" --threads 100000 train --config "$smoke" --run "$work/n8"
case_ "threads negative" --threads -- "$bin" --threads -1 train --config "$smoke" --run "$work/n9"
# Run folders written before issue 51 list the retired keys: at the values this build behaves as
# the run is used as it is (its config.yaml's bytes, hashed by its checkpoints, untouched); a run
# trained with a retired switch on is refused by every command that reads it.
as_older_build() {  # DIR EXPLORE: config.yaml as that build wrote it, LATEST's checkpoint under its hash
  python3 - "$1" "$2" <<'PY'
import re, sys
d, explore = sys.argv[1], sys.argv[2]
t = open(d + "/config.yaml").read()
t = t.replace("\nrace:\n", "\nrace:\n  goal_origin: center\n  observe_team_lanes: false\n", 1)
t = t.replace("\nhl:\n", "\nhl:\n  explore: " + explore + "\n  critic: shared\n  inference: eigen\n", 1)
t = t.replace("\npool:\n", "\npool:\n  p_center: 0\n", 1)
open(d + "/config.yaml", "w").write(t)
h = 1469598103934665603  # train::config_hash, FNV-1a
for b in t.encode():
    h = ((h ^ b) * 1099511628211) % 2**64
meta = d + "/checkpoint/" + open(d + "/checkpoint/LATEST").read().strip() + "/meta.yaml"
text = re.sub(r"config_hash: \d+", "config_hash: %d" % h, open(meta).read())
open(meta, "w").write(text)
PY
}
cp -r "$run" old_defaults && rm -f old_defaults/.lock && as_older_build old_defaults aircraft
cp -r "$run" old_team && rm -f old_team/.lock && as_older_build old_team team
old_yaml=$(md5sum < old_defaults/config.yaml)
accepted_ "a run listing retired keys at their values: tournament" -- "$bin" tournament --runs old_defaults --races 2 --out t_old
accepted_ "a run listing retired keys at their values: export" -- "$bin" export --run old_defaults --out old_export
accepted_ "a run listing retired keys at their values: replay" -- "$bin" replay --run old_defaults --out r_old
accepted_ "a run listing retired keys at their values: resume" -- "$bin" train --resume old_defaults --max-updates 3 --quiet
[ "$(md5sum < old_defaults/config.yaml)" = "$old_yaml" ] || { echo "FAIL: resume rewrote old_defaults/config.yaml"; fails=$((fails + 1)); }
case_ "a run trained with hl.explore team: tournament" "old_team/config.yaml: hl.explore: team was removed" -- "$bin" tournament --runs old_team --races 2 --out t_team
case_ "a run trained with hl.explore team: export" "hl.explore: team was removed" -- "$bin" export --run old_team --out team_export
case_ "a run trained with hl.explore team: replay" "hl.explore: team was removed" -- "$bin" replay --run old_team --out r_team
case_ "a run trained with hl.explore team: resume" "hl.explore: team was removed" -- "$bin" train --resume old_team
case_ "tournament missing run" -- "$bin" tournament --runs "$work/nothing" --out t1
case_ "tournament run twice" -- "$bin" tournament --runs "$run" "$run" --out t2
case_ "tournament 0 races" -- "$bin" tournament --runs "$run" --races 0 --out t3
case_ "tournament races text" -- "$bin" tournament --runs "$run" --races many --out t4
case_ "tournament batch 0" -- "$bin" tournament --runs "$run" --batch 0 --out t5
case_ "tournament epsilon 2" -- "$bin" tournament --runs "$run" --epsilon 2 --out t6
case_ "tournament one entry" -- "$bin" tournament --runs "$run" --no-untrained --out t7
case_ "tournament rule typo" -- "$bin" tournament --runs "$run@centre" --out t8
case_ "tournament autopilot shift without the autopilot" "--with-autopilot" -- "$bin" tournament --runs "$run" --set race.autopilot_shift_up_frac=-0.3 --out t20
case_ "tournament sets the tracks" "unknown key 'race.track' (known here: autopilot_airspeed_ftps" -- "$bin" tournament --runs "$run" --set race.track.n_waypoints=4 --out t22
case_ "tournament setting out of range" "race.goal_shift_up_frac: value 2 is out of range; allowed [-0.8, 0.8]" -- "$bin" tournament --runs "$run" --set race.goal_shift_up_frac=2 --out t23
case_ "tournament set outside race" "tournament sets race.goal_line_frac" -- "$bin" tournament --runs "$run" --set seed=3 --out t24
case_ "replay setting not a number" "race.goal_shift_up_frac: expected a number, got 'low'" -- "$bin" replay --run "$run" --set race.goal_shift_up_frac=low --out r23
case_ "tournament autopilot on line without the autopilot" "--with-autopilot" -- "$bin" tournament --runs "$run" --autopilot-on-line --out t21
"$bin" train --config "$smoke" --run other_ll --seed 2 --max-updates 1 --quiet >/dev/null || { echo "FAIL: setup run 2"; exit 1; }
case_ "tournament ensemble over two low levels" -- "$bin" tournament --runs "$run+other_ll" --out t16
case_ "tournament ensemble with a missing run" -- "$bin" tournament --runs "$run+$work/nothing" --out t17
case_ "tournament ensemble with an empty member" -- "$bin" tournament --runs "$run+" --out t18
case_ "tournament out under a device" -- "$bin" tournament --runs "$run" --races 2 --out /dev/null/t9
case_ "tournament negative seed" -- "$bin" tournament --runs "$run" --seed -1 --out t10
case_ "tournament rank outside the group" -- env WORLD_SIZE=2 RANK=2 "$bin" tournament --runs "$run" --out t11
case_ "tournament world size text" -- env WORLD_SIZE=two "$bin" tournament --runs "$run" --out t12
case_ "tournament master port 0" -- env WORLD_SIZE=2 MASTER_PORT=0 "$bin" tournament --runs "$run" --out t13
F16RACE_GROUP_TOKEN=0123456789abcdef0123 case_ "tournament no group there" "no group at" -- "$bin" tournament --runs "$run" --dist-world-size 2 --dist-rank 1 --dist-port 1 --dist-timeout 1 --out t14
case_ "launch without a command" -- "$bin" launch --nproc 2
case_ "launch 0 ranks" -- "$bin" launch --nproc 0 -- tournament --runs "$run"
case_ "launch itself" -- "$bin" launch --nproc 2 -- launch --nproc 2 -- race
case_ "tournament unknown network interface" -- env GLOO_SOCKET_IFNAME=nope0 "$bin" launch --nproc 2 --timeout 5 -- tournament --runs "$run" --races 2 --batch 2 --out t15
case_ "train: n_env over ranks" -- "$bin" launch --nproc 2 -- train --config "$smoke" --set race.n_env=3 --run "$work/ln"
case_ "train: one process's checkpoint by 2 ranks" -- "$bin" launch --nproc 2 -- train --resume "$run"
case_ "launch simulate" -- "$bin" launch --nproc 2 -- simulate --duration 1
case_ "replay missing run" -- "$bin" replay --run "$work/nothing" --out r1
case_ "replay bad opponent" -- "$bin" replay --run "$run" --opponent bogus --out r2
case_ "replay negative seed" -- "$bin" replay --run "$run" --seed -1 --out r3
case_ "replay out under a device" -- "$bin" replay --run "$run" --out /dev/null/r4
case_ "replay html empty" "--html" -- "$bin" replay --run "$run" --out r6 --html ""
case_ "replay html a folder" "--html" -- "$bin" replay --run "$run" --out r6 --html "$work"
case_ "replay html in out, foreign name" "--html" -- "$bin" replay --run "$run" --out r6 --html r6/page.html
case_ "replay html under a device" "/dev/null/race.html" -- "$bin" replay --run "$run" --out r6 --html /dev/null/race.html
case_ "export not a run" -- "$bin" export --run not_a_run --out e1
case_ "export out under a device" -- "$bin" export --run "$run" --out /dev/null/e2
"$bin" train --config "$smoke" --run "$work/ap_run" --set train.ll_pilot=autopilot --max-updates 1 --quiet >/dev/null ||
  { echo "FAIL: setup autopilot run"; exit 1; }
case_ "export an autopilot low level" -- "$bin" export --run "$work/ap_run" --out e3
case_ "ll_pilot unknown" "train.ll_pilot: 'pid'" -- $T --set train.ll_pilot=pid
case_ "simulate reference device" /dev/zero -- "$bin" simulate --reference /dev/zero --out s1.csv
case_ "simulate reference missing" nope.csv -- "$bin" simulate --reference nope.csv --out s2.csv
case_ "simulate header-only commands" header_only.csv -- "$bin" simulate --duration 1 --commands header_only.csv --out s3.csv
case_ "simulate time not increasing" "not_increasing.csv: t_s" -- "$bin" simulate --duration 1 --commands not_increasing.csv --out s4.csv
case_ "simulate text in commands" "not_number.csv:2: column 'Nz_ref_g'" -- "$bin" simulate --duration 1 --commands not_number.csv --out s5.csv
case_ "simulate ragged reference" ragged.csv:2 -- "$bin" simulate --reference ragged.csv --out s6.csv
case_ "simulate huge duration" "--duration 1e+09 s" -- "$bin" simulate --duration 1e9 --out s7.csv
case_ "simulate negative duration" --duration -- "$bin" simulate --duration -1 --out s8.csv
case_ "simulate unknown model" --model -- "$bin" simulate --duration 1 --model f22 --out s9.csv
case_ "simulate out under a device" /dev/null/s10.csv -- "$bin" simulate --duration 1 --out /dev/null/s10.csv
case_ "race 0 races" --races -- "$bin" race --races 0
case_ "race bad override" "race.n_env: expected an integer" -- "$bin" race --config "$smoke" --set race.n_env=abc --out ro
case_ "bench soak 0 steps" --aircraft-steps -- "$bin" bench soak --aircraft-steps 0
case_ "bench train missing config" nope.yaml -- "$bin" bench train --config nope.yaml
case_ "bench train, the second config broken" "duplicate.yaml:3" -- "$bin" bench train --config "$smoke" --config duplicate.yaml --updates 1 --repeat 1
# ... and it fails before the first config is timed: no result line for it.
n=$((n + 1))
out=$(timeout 60 "$bin" bench train --config "$smoke" --config duplicate.yaml --updates 1 --repeat 1 2>/dev/null)
if [[ "$out" == *"aircraft-steps/s"* ]]; then echo "FAIL [bench train timed a config before reading the next]: $out"; fails=$((fails + 1)); fi
# Issue 48: numbers outside their domain, on the command line and in configs (nan, inf, empty
# values, attention heads that do not divide the model width, tracks of gigabytes), each named.
case_ "config value empty" "race.n_env: expected an integer, got an empty value" -- $T --set race.n_env=
case_ "config value nan" "hl.gamma: value nan" -- $T --set hl.gamma=.nan
case_ "config path empty" "an empty config path" -- "$bin" train --config "" --run "$work/n10"
case_ "heads do not divide the width" "ll.n_heads (3) must divide ll.d_model (16)" -- $T --set ll.n_heads=3
case_ "track of gigabytes" "track.spacing_ft (1)" -- $T --set race.track.spacing_ft=1 --set race.track.leg_max_ft=1e6 --set race.track.n_waypoints=1000
case_ "simulate dt nan" "--dt: 'nan' is not a finite number" -- "$bin" simulate --duration 1 --dt nan --out s11.csv
case_ "simulate duration inf" "--duration: 'inf' is not a finite number" -- "$bin" simulate --duration inf --out s12.csv
case_ "simulate duration 1e308" "--duration 1e+308 s at --sample 0.02 s" -- "$bin" simulate --duration 1e308 --out s13.csv
case_ "simulate trim altitude empty" "--trim-alt: an empty value" -- "$bin" simulate --trim-alt "" --out s14.csv
case_ "tournament epsilon nan" "--epsilon: 'nan'" -- "$bin" tournament --runs "$run" --races 2 --epsilon nan --out t19
case_ "replay epsilon nan" "--epsilon: 'nan'" -- "$bin" replay --run "$run" --epsilon nan --out r5
case_ "train dist timeout nan" "--dist-timeout: 'nan'" -- $T --dist-timeout nan
case_ "train max updates empty" "--max-updates: an empty value" -- $T --max-updates ""
case_ "launch timeout nan" "--timeout: 'nan'" -- "$bin" launch --nproc 1 --timeout nan -- tournament --runs "$run"
case_ "race seed empty" "--seed: an empty value" -- "$bin" race --config "$smoke" --races 1 --seed "" --out ro
case_ "race plot beyond the races" "--plot 5: there are 1 races" -- "$bin" race --config "$smoke" --races 1 --plot 5 --out ro
case_ "bench soak steps nan" "--aircraft-steps: 'nan'" -- "$bin" bench soak --aircraft-steps nan --envs 2
case_ "bench sim threads huge" "--threads: Value 100000" -- "$bin" bench sim --aircraft 16 --substeps 2 --repeats 1 --threads 100000
# More memory than the machine has is the user's to size, not a bug (address space capped, so that
# a kernel that overcommits refuses it too instead of killing the process).
case_ "bench nets out of memory" "out of memory" -- bash -c 'ulimit -v 8000000 && exec "$0" "$@"' "$bin" bench nets --samples 10000000 --d-ego 100000 --repeats 1
# CSV inputs: a UTF-8 byte-order mark and Windows line ends are read; UTF-16, bare CR line ends,
# nan/inf cells and start states outside the model's domain are refused naming file, line, column.
cmd_file="$configs/manoeuvre_commands.csv" starts="$configs/gcas_starts.csv"
{ printf '\xEF\xBB\xBF'; sed 's/$/\r/' "$cmd_file"; } > bom_crlf_commands.csv
{ printf '\xEF\xBB\xBF'; sed 's/$/\r/' "$starts" | head -3; } > bom_crlf_starts.csv
tr '\n' '\r' < "$cmd_file" > cr_only.csv
printf '\xFF\xFEt\x00_\x00s\x00\n\x00' > utf16.csv
printf 't_s,Nz_ref_g\n0,0\n1,nan\n' > nan_commands.csv
printf 't_s,Nz_ref_g\n0,1e999\n' > overflow_commands.csv
state_header=$(head -1 "$starts") state_row=$(sed -n 2p "$starts")
with_state() {  # with_state FILE COLUMN VALUE [ROWS_BEFORE]: a start-state file with one cell changed
  { echo "$state_header"; [ -n "${4:-}" ] && echo "$state_row"
    echo "$state_row" | awk -F, -v c="$2" -v v="$3" 'BEGIN { OFS = "," } { $c = v; print }'; } > "$1"
}
with_state vt0_starts.csv 1 0
with_state alpha_starts.csv 2 1.2
with_state pow_starts.csv 13 150
with_state vt0_row3_starts.csv 1 0 second
with_state alt_nan_starts.csv 12 nan
refs=Nz_ref_g,ps_ref_radps,Ny_r_ref_mixed,throttle_ref_delta
printf 't_s,%s,int_e_Nz_gs,int_e_ps_rad,int_e_Ny_r_mixed_s,%s\n0,%s,0,0,0,0,0,0,0\n1,%s,0,0,0,0,0,0,0\n' \
  "$state_header" "$refs" "$(echo "$state_row" | sed 's/^[^,]*,[^,]*,/540,-0.5,/')" "$state_row" > alpha_reference.csv
printf '%s,throttle,elevator_deg,aileron_deg,rudder_deg\n%s,0.2,0,0,0\n' "$state_header" \
  "$(echo "$state_row" | sed 's/^[^,]*,/0,/')" > vt0_points.csv
printf 'e_ft,n_ft,alt_ft\nnan,3000,4000\n' > nan_waypoints.csv
accepted_ "commands with a byte-order mark and CRLF" -- "$bin" simulate --duration 3 --commands bom_crlf_commands.csv --out s15.csv
accepted_ "start states with a byte-order mark and CRLF" -- "$bin" simulate --autopilot gcas --init bom_crlf_starts.csv --duration 1 --out s16.csv
case_ "commands with bare CR line ends" "cr_only.csv:1: a carriage return" -- "$bin" simulate --duration 1 --commands cr_only.csv --out s17.csv
case_ "commands in UTF-16" "utf16.csv: is UTF-16" -- "$bin" simulate --duration 1 --commands utf16.csv --out s18.csv
case_ "commands nan cell" "nan_commands.csv:3: column 'Nz_ref_g' is 'nan'" -- "$bin" simulate --duration 1 --commands nan_commands.csv --out s19.csv
case_ "commands overflowing cell" "overflow_commands.csv:2: column 'Nz_ref_g'" -- "$bin" simulate --duration 1 --commands overflow_commands.csv --out s20.csv
case_ "start airspeed 0" "vt0_starts.csv:2: start state vt_ftps = 0" -- "$bin" simulate --autopilot gcas --init vt0_starts.csv --duration 1 --out s21.csv
case_ "start alpha beyond the tables" "alpha_starts.csv:2: start state alpha_rad = 1.2" -- "$bin" simulate --autopilot gcas --init alpha_starts.csv --duration 1 --out s22.csv
case_ "start power 150 %" "pow_starts.csv:2: start state pow_pct = 150" -- "$bin" simulate --autopilot gcas --init pow_starts.csv --duration 1 --out s23.csv
case_ "batch start airspeed 0 in row 2" "vt0_row3_starts.csv:3: start state vt_ftps" -- "$bin" simulate --autopilot gcas --init vt0_row3_starts.csv --duration 1 --out s24.csv
case_ "start altitude nan" "alt_nan_starts.csv:2: column 'alt_ft' is 'nan'" -- "$bin" simulate --autopilot gcas --init alt_nan_starts.csv --duration 1 --out s25.csv
case_ "reference start alpha beyond the tables" "alpha_reference.csv:2: start state alpha_rad = -0.5" -- "$bin" simulate --reference alpha_reference.csv --out s26.csv
case_ "derivative point at airspeed 0" "vt0_points.csv:2: state vt_ftps = 0" -- "$bin" simulate --derivatives vt0_points.csv --out s27.csv
case_ "waypoint nan" "nan_waypoints.csv:2: column 'e_ft'" -- "$bin" simulate --autopilot waypoint --init "$starts" --waypoints nan_waypoints.csv --duration 1 --out s28.csv
# metrics.csv read back on --resume: a row that is not one, a foreign header (copies of the run).
for m in abc_row foreign_header; do cp -r "$run" "metrics_$m" && rm -f "metrics_$m/.lock"; done
sed -i '2s/^[0-9]*,/abc,/' metrics_abc_row/metrics.csv
sed -i '1s/.*/time,value/' metrics_foreign_header/metrics.csv
case_ "resume: metrics row not a row" "metrics_abc_row/metrics.csv:2: 'abc' is not an update count" -- "$bin" train --resume metrics_abc_row
case_ "resume: metrics header foreign" "metrics_foreign_header/metrics.csv:1: not the header" -- "$bin" train --resume metrics_foreign_header
case_ "train --max-updates -1" "--max-updates" -- "$bin" train --config "$smoke" --run "$work/mu" --max-updates -1
printf 'base_config: %s\ntotal_env_steps: 9223372036854775808\n' "$smoke" > study_huge_steps.yaml
case_ "study total_env_steps beyond 2^62" "total_env_steps" -- "$bin" study --config study_huge_steps.yaml --out "$work/st6" --plan
# study: bad study configs, a base config with a typo, a folder of another configuration.
printf 'variants: [es, es_d9]\n' > study_bad_variant.yaml
printf 'seeds: [1, 1]\n' > study_dup_seed.yaml
printf 'jobz: 2\n' > study_typo.yaml
printf 'base_config: bad_syntax.yaml\n' > study_bad_base.yaml
printf 'base_config: %s\nvariants: [es_d3]\nseeds: [9]\ndt_hl_s: [2]\ntotal_env_steps: 5000\n' "$smoke" > study_other.yaml
mkdir -p study_out/dt2 && cp -r "$run" study_out/dt2/es_d3_s9 && rm -f study_out/dt2/es_d3_s9/.lock
case_ "study config missing" nope.yaml -- "$bin" study --config nope.yaml --out "$work/st1"
case_ "study unknown variant" "study_bad_variant.yaml: variants" -- "$bin" study --config study_bad_variant.yaml --out "$work/st2"
case_ "study duplicate seed" "study_dup_seed.yaml: seeds" -- "$bin" study --config study_dup_seed.yaml --out "$work/st3"
case_ "study unknown key" "unknown key 'jobz'" -- "$bin" study --config study_typo.yaml --out "$work/st4"
case_ "study base config broken" bad_syntax.yaml:3 -- "$bin" study --config study_bad_base.yaml --out "$work/st5"
case_ "study folder of another config" -- "$bin" study --config study_other.yaml --out study_out --plan
after=$(snapshot)
if [ "$before" != "$after" ]; then echo "FAIL: the trained run changed"; fails=$((fails + 1)); fi
echo "$((n - fails)) of $n hostile inputs handled (exit 2, a short message, no backtrace)"
[ "$fails" -eq 0 ]
