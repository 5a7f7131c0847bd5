#!/usr/bin/env bash
# Issue 49's pre-registered pilot A/Bs, in order, two seeds at a time (one thread each): every
# seed whose summary is not yet kept in experiments/notebook/data/ is trained and raced by
# experiments/scripts/seed_arm.sh; kept seeds are skipped, so the same command continues after a stop or on
# another machine. Commit the kept files as they come (git status shows them).
#
#   experiments/scripts/pilot_ab_queue.sh [ENTRY ...]     # default: 70 74 71 67
#
# Arms: 69 off (the control of them all, kept; the switches of 69's `on` arm and of 73 were
# removed after their verdicts); 70 ll.normalize_returns and 71 ll.init_at_trim (read and removed:
# their seeds need a build of c8c67be, F16RACE=...); 67 ll.gamma 0.995 (read); 74
# race.lane_error_average_s 8 (read and removed: a build of 46d4f04). Every seed of them is kept.
# 77 race.goal_bin_scale 0.5 (narrower lanes; read); 78 race.governor_sets_throttle_at_cap and 79
# that switch with 77's lanes (read and removed: a build of 0b55350); 80 race.governor_band_mach
# 0.01 (read and removed: a build of c3a8ae5). 86 race.goal_line_frac 0.25 (goals on a racing line;
# adopted: configs/default.yaml sets it since e0d56f0, so 86's `on` arm is the control of later A/Bs
# and 69's `off` arm is this build with --set race.goal_line_frac=0: the same bytes). 87: the
# default config with no override, the control of A/Bs run on its machine (AMD EPYC family 25);
# 88 race.preview_on_line (the task's preview points on the racing line) and 89
# race.lane_scales_with_radius (lanes inside the local tube), each against 87 (88 read and
# removed: a build of b8dcef3); 91 train.ll_throttle governor, against 87 (adopted:
# configs/default.yaml sets it, so 91's arm is the control of later A/Bs); 92 89's lanes on top
# of 91's throttle, against 91 (89 and 92 read and removed: a build of 0bda7d6); 94
# race.w_tube_wall 0.15 (a wall term inside the tube), against 91; 95 the same from 0.9 R (94 and 95
# read and removed: a build of 833c6d1); 96 race.governor_holds airspeed (one speed limit at
# every height), against 91 (read and removed: a build of d48ab5e); 98 race.goal_shift_up_frac -0.3
# (goals 0.3 R lower), against 91's runs raced against the autopilot tuned over heights (96's control_tuned;
# adopted: configs/default.yaml sets it since cd866df, so 98's arm is the control of later A/Bs);
# 99: the default config with no override (98's arm) on a third CPU (AMD EPYC family 23 model 1);
# 101: the same on an Intel Xeon family 6 model 167; 102 race.goal_line_frac 0.5 (the racing line
# within half the radius), against 101 on that CPU (read: not adopted); 103
# race.goal_shift_up_frac -0.5 (goals half the radius lower), against 98 on its CPU, after a check
# that this build trains 98's seed 1 to the same bytes; 105 train.ll_choice_snapshots 4 (the tail
# flown by the best of the last four low levels against the autopilot), paired with 98's seeds
# (read and removed: a build of f91e291).
# Runs go to runs/nbN/ARM/sS (not kept).
set -uo pipefail

run_job() {
  local e="$1" arm="$2" s="$3"
  shift 3
  mkdir -p "runs/nb$e"
  F16RACE_THREADS=1 experiments/scripts/seed_arm.sh "runs/nb$e/$arm" "experiments/notebook/data/$e/$arm" "$s" "$@" \
    > "runs/nb$e/${arm}_s$s.log" 2>&1 || echo "pilot_ab_queue: $e $arm s$s failed, see runs/nb$e/${arm}_s$s.log" >&2
}

# The whole queue is one function, read before it runs: editing this file while a queue runs
# cannot change what the running queue does next.
main() {
  here="$(cd "$(dirname "$0")/../.." && pwd)"
  cd "$here"
  entries=("$@")
  [ ${#entries[@]} -gt 0 ] || entries=(70 74 71 67)

  jobs=()  # "entry arm seed set-args"
  for e in "${entries[@]}"; do  # one entry's eight seeds before the next's: verdicts come in order
    for s in 1 2 3 4 5 6 7 8; do
      case "$e" in
        69) jobs+=("69 off $s") ;;
        70) jobs+=("70 on $s --set ll.normalize_returns=true") ;;
        71) jobs+=("71 on $s --set ll.init_at_trim=true") ;;
        67) jobs+=("67 on $s --set ll.gamma=0.995") ;;
        74) jobs+=("74 on $s --set race.lane_error_average_s=8") ;;
        77) jobs+=("77 on $s --set race.goal_bin_scale=0.5") ;;
        78) jobs+=("78 on $s --set race.governor_sets_throttle_at_cap=true") ;;
        79) jobs+=("79 on $s --set race.governor_sets_throttle_at_cap=true --set race.goal_bin_scale=0.5") ;;
        80) jobs+=("80 on $s --set race.governor_band_mach=0.01") ;;
        86) jobs+=("86 on $s --set race.goal_line_frac=0.25") ;;
        87) jobs+=("87 on $s") ;;  # the default config as it is (86's arm) on a second CPU
        88) jobs+=("88 on $s --set race.preview_on_line=true") ;;
        89) jobs+=("89 on $s --set race.lane_scales_with_radius=true") ;;
        91) jobs+=("91 on $s --set train.ll_throttle=governor") ;;
        92) jobs+=("92 on $s --set train.ll_throttle=governor --set race.lane_scales_with_radius=true") ;;
        94) jobs+=("94 on $s --set race.w_tube_wall=0.15") ;;
        95) jobs+=("95 on $s --set race.w_tube_wall=0.15 --set race.tube_wall_frac=0.9") ;;
        96) jobs+=("96 on $s --set race.governor_holds=airspeed") ;;
        98) jobs+=("98 on $s --set race.goal_shift_up_frac=-0.3") ;;
        99) jobs+=("99 on $s") ;;  # the default config as it is (98's arm) on a third CPU
        101) jobs+=("101 on $s") ;;  # the same on a fourth CPU
        102) jobs+=("102 on $s --set race.goal_line_frac=0.5") ;;
        103)  # 98's seed 1 again with this build first: the same bytes make 98's arm the control
          [ "$s" -eq 1 ] && jobs+=("103 check 1")
          jobs+=("103 on $s --set race.goal_shift_up_frac=-0.5") ;;
        105) jobs+=("105 on $s --set train.ll_choice_snapshots=4") ;;  # paired with 98's seeds
        *) echo "pilot_ab_queue: no pre-registered A/B $e (69's control, 70, 71, 67, 74, 77, 78, 79, 80, 86, 87, 88, 89, 91, 92, 94, 95, 96, 98, 99, 101, 102, 103 or 105)" >&2; exit 2 ;;
      esac
    done
  done

  running=0
  for j in "${jobs[@]}"; do
    read -r e arm s rest <<< "$j"
    [ -f "experiments/notebook/data/$e/$arm/s$s.json" ] && continue
    # shellcheck disable=SC2086  # rest is "--set KEY=VALUE ..." or empty
    run_job "$e" "$arm" "$s" $rest &
    running=$((running + 1))
    if [ "$running" -ge 2 ]; then wait -n; running=$((running - 1)); fi
  done
  wait
  echo "pilot_ab_queue: every seed of ${entries[*]} kept"
}

main "$@"
