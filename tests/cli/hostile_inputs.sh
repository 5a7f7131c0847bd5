#!/usr/bin/env bash
# Issue 15's hostile user, as a test: every case must end within 60 s with exit status 2, a short
# message on stderr (at most 3 lines), no "internal error", no C++ or LibTorch backtrace, and
# leave the trained run it may touch unchanged.
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
case_() {  # case_ DESCRIPTION -- COMMAND...
  local desc=$1
  shift 2
  n=$((n + 1))
  local out rc
  out=$(timeout 60 "$@" 2>&1 >/dev/null)
  rc=$?
  local lines
  lines=$(printf '%s\n' "$out" | grep -c .)
  if [ "$rc" -ne 2 ] || [ "$lines" -gt 3 ] || [[ "$out" == *"internal error"* ]] || [[ "$out" == *"Exception raised from"* ]] ||
     [[ "$out" == *"terminate called"* ]]; then
    echo "FAIL [$desc]: rc $rc, $lines lines: $out"
    fails=$((fails + 1))
  fi
}
T="$bin train --config $smoke --run $work/new"
case_ "config missing" -- "$bin" train --config nope.yaml --run "$work/n1"
case_ "config is a folder" -- "$bin" train --config "$work" --run "$work/n2"
case_ "config is a device" -- "$bin" train --config /dev/zero --run "$work/n3"
case_ "config is binary" -- "$bin" train --config binary.yaml --run "$work/n4"
case_ "YAML syntax" -- "$bin" train --config bad_syntax.yaml --run "$work/n5"
case_ "duplicate key" -- "$bin" train --config duplicate.yaml --run "$work/n6"
case_ "section not a mapping" -- "$bin" train --config not_mapping.yaml --run "$work/n7"
case_ "unknown key" -- $T --set foo=1
case_ "n_env 0" -- $T --set race.n_env=0
case_ "n_env text" -- $T --set race.n_env=abc
case_ "team_size 9" -- $T --set race.team_size=9
case_ "dt_ll 0" -- $T --set race.dt_ll_s=0
case_ "dt_hl tiny" -- $T --set race.dt_hl_s=0.01
case_ "dt_hl > time limit" -- $T --set race.time_limit_s=5 --set race.dt_hl_s=8
case_ "legs crossed" -- $T --set race.track.leg_min_ft=9000
case_ "radii crossed" -- $T --set race.track.radius_min_ft=2000
case_ "unknown model" -- $T --set race.model=jsbsim
case_ "unknown tube exit" -- $T --set race.tube_exit=maybe
case_ "unknown goal frame" -- $T --set race.goal_frame=polar
case_ "unknown agent" -- $T --set hl.agent=es_d4
case_ "epsilon 1.5" -- $T --set hl.epsilon=1.5
case_ "support crossed" -- $T --set hl.v_min=5 --set hl.v_max=1
case_ "one atom" -- $T --set hl.n_atoms=1
case_ "per-axis critic on es" -- $T --set hl.agent=es --set hl.critic=per_axis
case_ "per-axis target on es_d3" -- $T --set hl.agent=es_d3 --set hl.team_target=per_axis
case_ "team lane on es_d1" -- $T --set hl.agent=es_d1 --set hl.lateral=team
case_ "team explore scale without team draws" -- $T --set hl.team_explore_scale=0.25
case_ "empty hidden" -- $T --set "ll.hidden=[]"
case_ "zero hidden" -- $T --set "ll.hidden=[0]"
case_ "negative lr" -- $T --set ll.learning_rate=-1
case_ "negative steps" -- $T --set train.total_env_steps=-5
case_ "p_self_play 2" -- $T --set pool.p_self_play=2
case_ "center share in the tail without a tail" -- $T --set pool.p_center_tail=0.25
case_ "center share in the tail 1.5" -- $T --set train.hl_tail_share=0.3 --set pool.p_center_tail=1.5
case_ "weight average beyond the tail" -- $T --set train.hl_tail_share=0.3 --set train.hl_average_share=0.5
case_ "weight average share 1" -- $T --set train.hl_average_share=1
case_ "tail member without a tail" -- $T --set train.tail_member=1
case_ "tail members without a tail" -- $T --set train.hl_tail_members=3
case_ "tail members 17" -- $T --set train.hl_tail_share=0.3 --set train.hl_tail_members=17
case_ "tail members of a tail member" -- $T --set train.hl_tail_share=0.3 --set train.hl_tail_members=3 --set train.tail_member=1
case_ "--set without =" -- $T --set race.n_env
case_ "--set empty key" -- $T --set race..n_env=3
case_ "--set bad YAML" -- $T --set "race.n_env=[1"
case_ "negative seed" -- $T --seed -4
case_ "unknown agent flag" -- $T --agent es_d9
case_ "resume missing" -- "$bin" train --resume "$work/nothing"
case_ "resume with --seed" -- "$bin" train --resume "$run" --seed 3
case_ "fresh run over a run" -- "$bin" train --config "$smoke" --run "$run"
case_ "resume not a run" -- "$bin" train --resume not_a_run
case_ "resume corrupt LATEST" -- "$bin" train --resume corrupt_latest
case_ "resume truncated checkpoint" -- "$bin" train --resume truncated
case_ "threads huge" -- "$bin" --threads 100000 train --config "$smoke" --run "$work/n8"
case_ "threads negative" -- "$bin" --threads -1 train --config "$smoke" --run "$work/n9"
case_ "tournament missing run" -- "$bin" tournament --runs "$work/nothing" --out t1
case_ "tournament run twice" -- "$bin" tournament --runs "$run" "$run" --out t2
case_ "tournament 0 races" -- "$bin" tournament --runs "$run" --races 0 --out t3
case_ "tournament races text" -- "$bin" tournament --runs "$run" --races many --out t4
case_ "tournament batch 0" -- "$bin" tournament --runs "$run" --batch 0 --out t5
case_ "tournament epsilon 2" -- "$bin" tournament --runs "$run" --epsilon 2 --out t6
case_ "tournament one entry" -- "$bin" tournament --runs "$run" --no-untrained --out t7
case_ "tournament rule typo" -- "$bin" tournament --runs "$run@centre" --out t8
"$bin" train --config "$smoke" --run other_ll --seed 2 --max-updates 1 --quiet >/dev/null || { echo "FAIL: setup run 2"; exit 1; }
case_ "tournament ensemble over two low levels" -- "$bin" tournament --runs "$run+other_ll" --out t16
case_ "tournament ensemble with a missing run" -- "$bin" tournament --runs "$run+$work/nothing" --out t17
case_ "tournament ensemble with an empty member" -- "$bin" tournament --runs "$run+" --out t18
case_ "tournament out under a device" -- "$bin" tournament --runs "$run" --races 2 --out /dev/null/t9
case_ "tournament negative seed" -- "$bin" tournament --runs "$run" --seed -1 --out t10
case_ "tournament rank outside the group" -- env WORLD_SIZE=2 RANK=2 "$bin" tournament --runs "$run" --out t11
case_ "tournament world size text" -- env WORLD_SIZE=two "$bin" tournament --runs "$run" --out t12
case_ "tournament master port 0" -- env WORLD_SIZE=2 MASTER_PORT=0 "$bin" tournament --runs "$run" --out t13
case_ "tournament no group there" -- "$bin" tournament --runs "$run" --dist-world-size 2 --dist-rank 1 --dist-port 1 --dist-timeout 1 --out t14
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
case_ "export not a run" -- "$bin" export --run not_a_run --out e1
case_ "export out under a device" -- "$bin" export --run "$run" --out /dev/null/e2
"$bin" train --config "$smoke" --run "$work/ap_run" --set train.ll_pilot=autopilot --max-updates 1 --quiet >/dev/null ||
  { echo "FAIL: setup autopilot run"; exit 1; }
case_ "export an autopilot low level" -- "$bin" export --run "$work/ap_run" --out e3
case_ "ll_pilot unknown" -- $T --set train.ll_pilot=pid
case_ "simulate reference device" -- "$bin" simulate --reference /dev/zero --out s1.csv
case_ "simulate reference missing" -- "$bin" simulate --reference nope.csv --out s2.csv
case_ "simulate header-only commands" -- "$bin" simulate --duration 1 --commands header_only.csv --out s3.csv
case_ "simulate time not increasing" -- "$bin" simulate --duration 1 --commands not_increasing.csv --out s4.csv
case_ "simulate text in commands" -- "$bin" simulate --duration 1 --commands not_number.csv --out s5.csv
case_ "simulate ragged reference" -- "$bin" simulate --reference ragged.csv --out s6.csv
case_ "simulate huge duration" -- "$bin" simulate --duration 1e9 --out s7.csv
case_ "simulate negative duration" -- "$bin" simulate --duration -1 --out s8.csv
case_ "simulate unknown model" -- "$bin" simulate --duration 1 --model f22 --out s9.csv
case_ "simulate out under a device" -- "$bin" simulate --duration 1 --out /dev/null/s10.csv
case_ "race 0 races" -- "$bin" race --races 0
case_ "race bad override" -- "$bin" race --set race.n_env=abc
case_ "bench soak 0 steps" -- "$bin" bench soak --aircraft-steps 0
case_ "bench train missing config" -- "$bin" bench train --config nope.yaml
case_ "bench train, the second config broken" -- "$bin" bench train --config "$smoke" --config duplicate.yaml --updates 1 --repeat 1
# ... and it fails before the first config is timed: no result line for it.
n=$((n + 1))
out=$(timeout 60 "$bin" bench train --config "$smoke" --config duplicate.yaml --updates 1 --repeat 1 2>/dev/null)
if [[ "$out" == *"aircraft-steps/s"* ]]; then echo "FAIL [bench train timed a config before reading the next]: $out"; fails=$((fails + 1)); fi
# study: bad study configs, a base config with a typo, a folder of another configuration.
printf 'variants: [es, es_d9]\n' > study_bad_variant.yaml
printf 'seeds: [1, 1]\n' > study_dup_seed.yaml
printf 'jobz: 2\n' > study_typo.yaml
printf 'base_config: bad_syntax.yaml\n' > study_bad_base.yaml
printf 'base_config: %s\nvariants: [es_d3]\nseeds: [9]\ndt_hl_s: [2]\ntotal_env_steps: 5000\n' "$smoke" > study_other.yaml
mkdir -p study_out/dt2 && cp -r "$run" study_out/dt2/es_d3_s9 && rm -f study_out/dt2/es_d3_s9/.lock
case_ "study config missing" -- "$bin" study --config nope.yaml --out "$work/st1"
case_ "study unknown variant" -- "$bin" study --config study_bad_variant.yaml --out "$work/st2"
case_ "study duplicate seed" -- "$bin" study --config study_dup_seed.yaml --out "$work/st3"
case_ "study unknown key" -- "$bin" study --config study_typo.yaml --out "$work/st4"
case_ "study base config broken" -- "$bin" study --config study_bad_base.yaml --out "$work/st5"
case_ "study folder of another config" -- "$bin" study --config study_other.yaml --out study_out --plan
after=$(snapshot)
if [ "$before" != "$after" ]; then echo "FAIL: the trained run changed"; fails=$((fails + 1)); fi
echo "$((n - fails)) of $n hostile inputs handled (exit 2, a short message, no backtrace)"
[ "$fails" -eq 0 ]
