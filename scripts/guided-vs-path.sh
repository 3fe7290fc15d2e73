#!/usr/bin/env bash
# `guided` against `path` (issue 39's protocol; a benchmark, never a test). For each scene and
# seed both render side by side in one run, one thread each, then `rdr compare` gives each
# image's relative MSE against the Mitsuba reference (cbox_path -> cbox, veach_path -> veach,
# a path to an XML/JSON scene -> its directory's reference.exr, if any).
#
#   scripts/guided-vs-path.sh RDR SECS "SEEDS" SCENE...
#   e.g. scripts/guided-vs-path.sh /tmp/rdr 60 "1 2 3" caustic_cbox env_sphere
#
# Modes (environment):
#   SPP=N          equal spp instead of equal time: N spp each, no time limit; the figure of
#                  merit is relMSE x CPU seconds (user + system, from /usr/bin/time)
#   REPEAT=N       with SPP: the renders of a scene and seed run one after another instead
#                  of side by side (path, guided, the others, and again), N rounds, and each
#                  render's CPU time is its least of the N, as speed is measured (alternate
#                  binaries, best of several): a render's image depends on seed and spp only
#                  (a repeat's must equal the first: checked), and one run's CPU time on a
#                  shared VM moves by 10-15 % (cbox_path's path at 256 spp: 13.3-18.4 s)
#   PAIRED=1       with SPP and REPEAT: each round runs path and guided side by side, each
#                  pinned to its own core (the cores swapped every round), and the core that
#                  finishes first goes on with a `path` render of the scene (untimed, stopped
#                  when the other ends), so that each timed render has a busy neighbour for
#                  its whole run; the cost ratio is the median over the rounds of guided's CPU
#                  time over path's in the same round (each round's is printed). Machine load
#                  that comes and goes then slows both renders of a round alike: on a shared
#                  VM the ratios of a round stay within a few per cent (a run's median moves
#                  by up to 4 % from one hour to the next) where the least of N serial CPU
#                  times moves by 10-20 %. Not with BASE, VARIANTS, LOAD or COST
#   COST=instructions  with SPP: the cost is the instructions a render executes instead of
#                  its CPU seconds (valgrind's callgrind, no cache simulation: about 30x slower,
#                  one render at a time per core); it does not depend on the machine's load,
#                  but counts no cache miss (a render that waits on memory looks cheaper than
#                  it is) and runs the AVX2 kernels (valgrind has no AVX-512; images are the same);
#                  not with REPEAT (a count does not change from one run to the next)
#   LOAD=1         a third render (`path` on cbox_path, one thread) runs beside the pair for
#                  the whole run: the loaded case (the schedule must not care)
#   GUIDED='{...}' extra override for `guided` (e.g. '{"integrator":{"target":"variance"}}'
#                  to measure one switch on and off; the default: none)
#   BASE=RDR2      a second binary whose `guided` renders beside too (before/after in one run);
#   BASE_GUIDED='{...}' its extra override (BASE=RDR, GUIDED and BASE_GUIDED: a switch on and off)
#   VARIANTS='tag={...} tag2={...}'  more `guided` renders of RDR beside, one per tag with its override
#                  (no spaces inside an override), e.g. VARIANTS='paths={"integrator":{"learn_from":"paths"}}'
#   OUT=DIR        images and logs (default /tmp/guided-vs-path)
#   REF=PATH       (no .exr) the reference of scene files given by path (PATH.var.exr is used
#                  when it exists), e.g. REF=/work/perf-refs/veach-mis for the real veach-mis
#
# Prints one line per image (relMSE, spp reached, CPU s) and per scene and seed the ratio
# guided/path of relMSE (equal time) or of relMSE x CPU s (equal spp). Copy RDR out of
# target/ first if tests may rebuild it meanwhile. Name the CPU (lscpu) with every figure.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
refs=$(realpath -m "${SHARED:-$here/../shared}")/refs
rdr=$1 secs=$2 seeds=$3
shift 3
out=${OUT:-/tmp/guided-vs-path}
guided_extra=${GUIDED:-'{}'}
mkdir -p "$out"
case ${COST:-} in
  '') ;;
  instructions)
    [[ -n ${SPP:-} ]] || { echo "COST=instructions needs SPP (equal spp)" >&2; exit 2; }
    [[ -z ${REPEAT:-} ]] || { echo "COST=instructions counts the same every run: no REPEAT" >&2; exit 2; }
    command -v valgrind >/dev/null || { echo "COST=instructions needs valgrind (apt-get install valgrind)" >&2; exit 2; }
    ;;
  *) echo "COST is 'instructions' or unset, not '$COST'" >&2; exit 2 ;;
esac
if [[ -n ${PAIRED:-} ]]; then
  [[ -n ${SPP:-} && -n ${REPEAT:-} ]] || { echo "PAIRED needs SPP and REPEAT" >&2; exit 2; }
  [[ -z ${BASE:-}${VARIANTS:-}${LOAD:-}${COST:-} ]] || { echo "PAIRED takes path and guided alone (no BASE, VARIANTS, LOAD or COST)" >&2; exit 2; }
  [[ $(nproc) -ge 2 ]] || { echo "PAIRED needs two cores" >&2; exit 2; }
fi
lscpu | grep -E '^Model name' || true

if [[ -n ${LOAD:-} ]]; then
  "$rdr" render "$refs/scenes/cbox_path.json" --spp 1000000 --threads 1 -q -o "$out/load.exr" >/dev/null 2>&1 &
  load_pid=$!
  trap 'kill $load_pid 2>/dev/null || true' EXIT
fi

scene_and_ref() {
  case $1 in
    *.xml | *.json) scene=$1 ref=${REF:-$(dirname "$1")/reference} ;;
    cbox_path) scene=$refs/scenes/$1.json ref=$refs/cbox ;;
    veach_path) scene=$refs/scenes/$1.json ref=$refs/veach ;;
    *) scene=$refs/scenes/$1.json ref=$refs/$1 ;;
  esac
}

for sc in "$@"; do
  scene_and_ref "$sc"
  name=$(basename "${sc%.*}")
  for seed in $seeds; do
    if [[ -n ${SPP:-} ]]; then
      common=(--spp "$SPP" --threads 1 --seed "$seed")
    else
      common=(--spp 1000000 --time-limit "$secs" --threads 1 --seed "$seed")
    fi
    run() { # tag binary override...
      local tag=$1 bin=$2
      shift 2
      local counter=()
      [[ ${COST:-} == instructions ]] &&
        counter=(valgrind --tool=callgrind --cache-sim=no --branch-sim=no --callgrind-out-file=/dev/null)
      local pinned=()
      [[ -n ${pin:-} ]] && pinned=(taskset -c "$pin")
      "${pinned[@]}" /usr/bin/time -f 'cpu %U %S' -o "$out/$name.$tag.$seed.time" \
        "${counter[@]}" "$bin" render "$scene" "$@" "${common[@]}" -o "$out/$name.$tag.$seed.exr" >"$out/$name.$tag.$seed.log" 2>&1
    }
    start() { # runs a render: in the background (side by side), or to its end with REPEAT
      if [[ -n ${SPP:-} && -n ${REPEAT:-} ]]; then
        run "$@"
      else
        run "$@" &
        pids+=($!)
      fi
    }
    paired() { # path and guided side by side on cores $1 and $2, a filler after the first ends
      pin=$1 run "path$round" "$rdr" &
      local p=$!
      pin=$2 run "guided$round" "$rdr" --override '{"integrator":{"type":"guided"}}' --override "$guided_extra" &
      local g=$! done_pid filler
      wait -n -p done_pid "$p" "$g"
      local free=$1 other=$g
      [[ $done_pid == "$g" ]] && free=$2 other=$p
      taskset -c "$free" "$rdr" render "$scene" --override '{"integrator":{"type":"path"}}' --spp 1000000 --threads 1 \
        --seed "$seed" -q -o "$out/filler.exr" >/dev/null 2>&1 &
      filler=$!
      wait "$other"
      kill "$filler" 2>/dev/null || true
      wait "$filler" 2>/dev/null || true
    }
    group() { # one render of each tag; $round names the repeat (empty: the first)
      tags=(path guided)
      if [[ -n ${PAIRED:-} ]]; then
        local r=${round#.r}
        if ((${r:-1} % 2)); then paired 0 1; else paired 1 0; fi
        return
      fi
      pids=()
      start "path$round" "$rdr"
      start "guided$round" "$rdr" --override '{"integrator":{"type":"guided"}}' --override "$guided_extra"
      if [[ -n ${BASE:-} ]]; then
        tags+=(base)
        start "base$round" "$BASE" --override '{"integrator":{"type":"guided"}}' --override "${BASE_GUIDED:-{\}}"
      fi
      for v in ${VARIANTS:-}; do
        tags+=("${v%%=*}")
        start "${v%%=*}$round" "$rdr" --override '{"integrator":{"type":"guided"}}' --override "${v#*=}"
      done
      [[ ${#pids[@]} -eq 0 ]] || wait "${pids[@]}" # not the load
    }
    round='' group
    repeats=1
    [[ -n ${SPP:-} ]] && repeats=${REPEAT:-1}
    for ((r = 2; r <= repeats; r++)); do
      round=".r$r" group
      for i in "${tags[@]}"; do
        same=$("$rdr" compare "$out/$name.$i.r$r.$seed.exr" "$out/$name.$i.$seed.exr" | grep '^relMSE' | head -1)
        if ! grep -qE '\b0(\.0+)?e0\b|\b0\.0+\b' <<<"$same"; then
          echo "$name seed $seed $i: repeat $r differs from the first ($same)" >&2
          exit 1
        fi
      done
    done

    declare -A merit=() cpus=() rels=()
    for i in "${tags[@]}"; do
      variance=()
      [[ -f $ref.var.exr ]] && variance=(--variance "$ref.var.exr")
      m=$("$rdr" compare "$out/$name.$i.$seed.exr" "$ref.exr" "${variance[@]}" | grep '^relMSE' | head -1)
      rel=$(grep -oE '[0-9.]+e[-+]?[0-9]+|[0-9]+\.[0-9]+' <<<"$m" | head -1)
      times=("$out/$name.$i.$seed.time")
      for ((r = 2; r <= repeats; r++)); do times+=("$out/$name.$i.r$r.$seed.time"); done
      cpu=$(awk '/^cpu/ {c = $2 + $3; if (best == "" || c < best) best = c} END {print best}' "${times[@]}")
      cost=$cpu unit='CPU s'
      if [[ -n ${PAIRED:-} ]]; then
        # each round's CPU time (in the order of the rounds); the merit below takes the
        # median of the rounds' ratios instead of the least times
        cpus[$i]=$(awk '/^cpu/ {printf "%s ", $2 + $3}' "${times[@]}")
        rels[$i]=$rel
      fi
      if [[ ${COST:-} == instructions ]]; then
        cost=$(grep -oE 'refs: +[0-9,]+' "$out/$name.$i.$seed.log" | grep -oE '[0-9,]+$' | tr -d ,)
        unit=instructions
      fi
      spp=$(grep -oE 'at [0-9]+ spp' "$out/$name.$i.$seed.log" | head -1)
      if [[ -n ${SPP:-} ]]; then
        merit[$i]=$(awk -v r="$rel" -v c="$cost" 'BEGIN {print r * c}')
      else
        merit[$i]=$rel
      fi
      echo "$name seed $seed $i: $m | $spp | cpu ${cpu} s${COST:+ | $cost $unit}"
    done
    if [[ -n ${PAIRED:-} ]]; then
      awk -v n="$name" -v s="$seed" -v g="${cpus[guided]}" -v p="${cpus[path]}" -v rg="${rels[guided]}" -v rp="${rels[path]}" \
        'BEGIN {
          k = split(g, gs, " "); split(p, ps, " ")
          for (j = 1; j <= k; j++) { q[j] = gs[j] / ps[j]; line = line sprintf(" %.3f", q[j]) }
          for (a = 1; a <= k; a++) for (b = a + 1; b <= k; b++) if (q[b] < q[a]) { t = q[a]; q[a] = q[b]; q[b] = t }
          med = (k % 2) ? q[(k + 1) / 2] : (q[k / 2] + q[k / 2 + 1]) / 2
          printf "%s seed %s: guided/path CPU time by round%s (median %.3f)\n", n, s, line, med
          printf "%s seed %s: guided/path relMSE x CPU s %.3f (paired: relMSE ratio x median CPU ratio)\n", n, s, rg / rp * med
        }'
      unset merit cpus rels
      continue
    fi
    for i in "${tags[@]:1}"; do
      awk -v n="$name" -v s="$seed" -v i="$i" -v g="${merit[$i]}" -v p="${merit[path]}" -v spp="${SPP:-}" \
        -v unit="${unit:-CPU s}" \
        'BEGIN {printf "%s seed %s: %s/path %s %.3f\n", n, s, i, (spp == "" ? "relMSE" : "relMSE x " unit), g / p}'
    done
    unset merit
  done
done
