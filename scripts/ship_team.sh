#!/usr/bin/env bash
# Ships a trained run as examples/trained_team/, the team `replay`, `tournament`,
# `export` and Python's f16race.load_policy use with no training: the run's policy-only copy
# (`f16race export --policy-run`: config.yaml, checkpoint/LATEST and its checkpoint's meta.yaml,
# ll.pt and hl.pt without optimiser state, the same for each tail member under members/), its
# TorchScript export in export/ (what load_policy reads), and provenance.md after racing it against
# its controls and the autopilot. Refuses a team of 2 MB or more, counting files with the same
# bytes once, as git stores them (each tail member's ll.pt is the run's own), and leaves the
# shipped team as it was.
#
# usage: scripts/ship_team.sh RUN ["TRAIN COMMAND"]
#   F16RACE=path/to/f16race (default build/f16race); RACES per pairing for provenance (default 256);
#   TRAINED_BY="the build that trained RUN, when not this one" (e.g. "commit 619e12e")
set -euo pipefail
cd "$(dirname "$0")/.."
run=${1:?usage: scripts/ship_team.sh RUN [\"TRAIN COMMAND\"]}
command_used=${2:-}
bin=${F16RACE:-build/f16race}
races=${RACES:-256}
dest=examples/trained_team
stage=examples/.trained_team.tmp
limit=$((2 * 1000 * 1000))

[ -x "$bin" ] || { echo "ship_team: $bin: no f16race binary (build first, or set F16RACE)" >&2; exit 2; }

# The run's policy-only copy (export --policy-run: config.yaml, checkpoint/LATEST and the checkpoint
# it names with meta.yaml, ll.pt and hl.pt without optimiser state, the same for each tail member)
# is staged and must load (its export is written) before it replaces the old team; the export that
# ships is written again from its final place, which its README names.
rm -rf "$stage"
"$bin" export --run "$run" --policy-run "$stage" >/dev/null
work=$(mktemp -d)
trap 'rm -rf "$work" "$stage"' EXIT
bytes=$(find "$stage" -type f -exec sha256sum {} + | sort -k1,1 -u | awk '{print $2}' | xargs stat -c %s |
        awk '{s += $1} END {print s}')
if [ "$bytes" -ge "$limit" ]; then
  echo "ship_team: $run's policy-only copy holds $bytes bytes (distinct files), over the 2 MB limit; its largest files:" >&2
  find "$stage" -type f -printf '%s %p\n' | sort -rn | head -5 >&2
  exit 1
fi
[ -f "$dest/README.md" ] && cp "$dest/README.md" "$stage/"  # the folder's own description stays
rm -rf "$dest"
mv "$stage" "$dest"
"$bin" export --run "$dest" >/dev/null

"$bin" tournament --runs "$dest" --controls --with-autopilot --no-untrained --races "$races" --out "$work/tour" >/dev/null
seed=$(sed -n 's/^seed: *\([0-9]*\).*/\1/p' "$dest/config.yaml" | head -1)
steps=$(sed -n 's/^env_steps: *//p' "$dest/checkpoint/$(cat "$dest/checkpoint/LATEST")/meta.yaml")
{
  echo "# The shipped team: provenance"
  echo
  echo "Written by scripts/ship_team.sh from \`$run\` on $(date -u +%Y-%m-%d); see docs/viewer.md, \"The shipped team\"."
  echo
  echo "- built from: $("$bin" --version)"
  cpu() { sed -n "s/^$1[[:space:]]*: //p" /proc/cpuinfo | head -1; }
  echo "- CPU: $(cpu 'model name') (family $(cpu 'cpu family') model $(cpu model)), $(nproc) cores"
  [ -z "${TRAINED_BY:-}" ] || echo "- trained by: f16race at $TRAINED_BY"
  echo "- seed: ${seed:-1}; $steps env steps"
  echo "- command: \`${command_used:-f16race train --seed ${seed:-1} --run RUN with the config.yaml shipped here}\`"
  echo "- size: $bytes bytes of distinct files"
  echo
  echo "Tournament (\`f16race tournament --runs $dest --controls --with-autopilot --no-untrained --races $races\`):"
  echo
  echo "| pairing | races | winrate [95% Wilson] |"
  echo "|---|---|---|"
  awk -F, 'NR > 1 && $7 == "trained_team" { printf "| trained_team vs %s | %d | %.3f [%.3f, %.3f] |\n", $8, $4, $3, $5, $6 }' \
    "$work/tour/pairings.csv"
} > "$dest/provenance.md"
echo "shipped $run as $dest ($bytes bytes); provenance:"
cat "$dest/provenance.md"
